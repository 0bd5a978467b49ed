"""Effect families, each in physically different implementations from two independent generators,
and how a diagnosis of their logs is scored.

The truth side of the implementation-robustness checks: the families and the cases are defined
here from the physics of the generators (:mod:`mjtrack.testing.diagnose_physics`, "A", and
:mod:`mjtrack.testing.bristle_physics`, "B"), not from the diagnosis; :func:`score` reads a
diagnosis only through its ``findings`` and ``chosen`` (each with ``effect.name``,
``estimate``, ``interval``, ``tied_with``).

Families (what a user acts on): the diagnosis's effect names grouped by the physical cause they
stand for (:data:`FAMILY`):

* ``drive_response``: the drive reaches the commanded speed late (actuator_lag, command_delay);
* ``drive_saturation``: the drive cannot reach it at all (speed_limit, drive_turn_limit);
* ``drive_gain``: it reaches another speed (track_speed_scale);
* ``mass``: where the weight sits (cg_offset_x, cg_offset_y);
* ``ground``: the contact (friction_scale, friction_asymmetry, icr_spread, ground_anisotropy,
  road_wheels);
* ``terrain``: a slope.

Cases (:data:`CASES`): every implementation in both generators, 60 s of held random commands at
20 Hz, pose only with 5 mm pose noise. What counts as right for each (``families``: all must be
named; ``effects``: when given, the effect a drive-response family must be named by, unless it is
reported tied with the other one):

* ``lag_speed``: a first-order lag on the speed set-point (A: on the track speed itself) ->
  drive_response, by actuator_lag (a lag named a delay without a tie is wrong);
* ``lag_force``: a lag on the drive force moving the belt's inertia (A: unloaded belt, a
  second-order response; B: the loaded belt with a retuned PI loop, which also sags under the
  turning load) -> drive_response, by either (a second-order lag is neither exactly);
* ``dead_time``: a transport delay (A: of the commands; B: of the controller's input, quantised
  to its tick) -> drive_response, by command_delay;
* ``rate_limit``: a slew limit of the track speed (A) or of the set-point (B). The vocabulary has
  no slew limit; physically the drive reaches the speed late -> drive_response, by either;
* ``force_limit``: the drive force saturates (A: massless belts, the traction of spins and hard
  turns is limited; B: the belt's inertia, so mostly its acceleration is limited) ->
  drive_saturation or drive_response, by either;
* ``ground_coulomb``: friction asymmetry mu_L = 0.6 mu_R on Coulomb ground -> ground (the
  traction-ratio twin cg_offset_y counts when tied with it);
* ``ground_aniso``: anisotropic ground, lateral friction 0.5 x longitudinal -> ground;
* ``cg_x``: a control, the centre of mass 6 cm forward -> mass;
* ``lag_cg``: lag 0.25 s and the centre of mass 4 cm back -> drive_response (by actuator_lag) and
  mass;
* ``lag_light``: a 0.2 s set-point lag on an 8 kg robot -> drive_response, by actuator_lag;
* ``clean``: nothing -> no finding.

Scoring (:func:`score`): ``missing`` = true families that no finding (chosen or tied) names;
``extra`` = chosen findings of another family, not tied with a finding of a true family (a
finding tied with the truth is a reported tie, never an extra); ``confused`` = a drive-response
case whose required effect is neither chosen nor tied. Verdict: "right" (nothing missing, nothing
extra, not confused; "tie" when a chosen finding is reported tied with another), "wrong" (a true
family missing and another named, or confused), "spurious" (the truth named plus an extra),
"missed" (a true family missing, nothing else named).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjtrack.io.robot import Robot
from mjtrack.testing import bristle_physics, diagnose_physics

FAMILY = {
    "drive_lag": "drive_response", "drive_delay": "drive_response",
    "drive_speed_limit": "drive_saturation", "drive_turn_limit": "drive_saturation",
    "drive_accel_limit": "drive_response", "drive_force_limit": "drive_response",
    "track_speed_scale": "drive_gain",
    "cg_x": "mass", "cg_y": "mass",
    "friction_scale": "ground", "mu_ratio": "ground", "icr_spread": "ground",
    "ground_anisotropy": "ground", "road_wheels": "ground",
    "slope": "terrain",
}
GENERATORS = ("A", "B")
DURATION = 60.0  # [s]
RATE = 20.0  # [Hz]
POSE_STD = 0.005  # [m]


@dataclass(frozen=True)
class Case:
    """One implementation of one family in both generators (module docstring).

    Args:
        name: the case's name.
        families: the families a diagnosis must name (empty: a clean log).
        params: generator -> its effect parameters.
        effect: the effect that must name drive_response (or be tied), None: either.
        mass: the robot's mass [kg] when not the default description's.
        truth: parameter of the diagnosis's vocabulary -> the value it stands for, when an
            implementation is the vocabulary's own (for the estimate columns).
    """

    name: str
    families: tuple[str, ...]
    params: dict = field(default_factory=dict)
    effect: str | None = None
    mass: float | None = None
    truth: dict = field(default_factory=dict)


CASES = (
    Case("clean", (), {"A": {}, "B": {}}),
    Case("lag_speed", ("drive_response",), {"A": {"actuator_lag": 0.35}, "B": {"lag": 0.35}}, "drive_lag",
         truth={"drive_lag": 0.35}),
    Case("lag_force", ("drive_response",), {"A": {"force_lag": 0.15}, "B": {"force_lag": 0.15}}),
    Case("dead_time", ("drive_response",), {"A": {"command_delay": 0.25}, "B": {"dead_time": 0.25}},
         "drive_delay", truth={"drive_delay": 0.25}),
    Case("rate_limit", ("drive_response",), {"A": {"rate_limit": 1.5}, "B": {"rate_limit": 1.5}}),
    Case("force_limit", ("drive_saturation|drive_response",), {"A": {"force_limit": 55.0},
                                                                "B": {"force_limit": 250.0}}),
    Case("ground_coulomb", ("ground",), {"A": {"friction_asymmetry": 0.6}, "B": {"friction_asymmetry": 0.6}},
         truth={"mu_ratio": 0.6}),
    Case("ground_aniso", ("ground",), {"A": {"lateral_ratio": 0.5}, "B": {"lateral_ratio": 0.5}}),
    Case("cg_x", ("mass",), {"A": {"cg_offset_x": 0.06}, "B": {"cg_offset_x": 0.06}}, truth={"cg_x": 0.06}),
    Case("lag_cg", ("drive_response", "mass"), {"A": {"actuator_lag": 0.25, "cg_offset_x": -0.04},
                                                "B": {"lag": 0.25, "cg_offset_x": -0.04}}, "drive_lag",
         truth={"drive_lag": 0.25, "cg_x": -0.04}),
    Case("lag_light", ("drive_response",), {"A": {"actuator_lag": 0.2}, "B": {"lag": 0.2}}, "drive_lag",
         mass=8.0, truth={"drive_lag": 0.2}),
    # a compound of one family: its verdict asks for the family; whether both were named, or tied,
    # is :func:`truth_named`'s
    Case("lag_delay", ("drive_response",), {"A": {"actuator_lag": 0.2, "command_delay": 0.15},
                                            "B": {"lag": 0.2, "dead_time": 0.15}},
         truth={"drive_lag": 0.2, "drive_delay": 0.15}),
)
BY_NAME = {c.name: c for c in CASES}


def make_case_log(case: Case, generator: str, *, seed: int = 1):
    """The case's log from ``generator`` ("A" or "B"); returns (log, the nominal description)."""
    robot = Robot() if case.mass is None else Robot(mass=case.mass)
    p = dict(case.params[generator])
    if generator == "A":
        return diagnose_physics.make_log(p, robot=robot, seed=seed, duration=DURATION, rate=RATE, pose_std=POSE_STD)
    if generator == "B":
        return bristle_physics.make_log(p, robot=robot, seed=seed, duration=DURATION, rate=RATE, pose_std=POSE_STD)
    raise ValueError(f"unknown generator {generator!r}")


def _accepts(families: tuple[str, ...], name: str) -> int | None:
    """Index of the true family (alternatives joined by "|") the effect ``name`` belongs to, or None."""
    fam = FAMILY.get(name)
    for i, f in enumerate(families):
        if fam in f.split("|"):
            return i
    return None


def score(diagnosis, case: Case) -> dict:
    """The verdict on a diagnosis of the case's log (module docstring): {"verdict", "missing",
    "extra", "ties", "confused", "named"}."""
    findings = list(diagnosis.findings)
    chosen = list(diagnosis.chosen)
    by_name = {f.effect.name: f for f in findings}
    named = {i for f in findings for i in [_accepts(case.families, f.effect.name)] if i is not None}
    missing = [f for i, f in enumerate(case.families) if i not in named]
    extra, ties = [], []
    for c in chosen:
        mine = _accepts(case.families, c.effect.name) is not None
        partners = [n for n in c.tied_with if n in by_name]
        if not mine and not any(_accepts(case.families, n) is not None for n in partners):
            extra.append(c.effect.name)
        ties += [f"{c.effect.name}~{n}" for n in partners]
    confused = False
    if case.effect is not None and not missing:
        names = {f.effect.name for f in findings}
        confused = case.effect not in names
    if missing and (extra or confused):
        verdict = "wrong"
    elif confused:
        verdict = "wrong"
    elif missing:
        verdict = "missed"
    elif extra:
        verdict = "spurious"
    else:
        verdict = "tie" if ties else "right"
    return {"verdict": verdict, "missing": missing, "extra": extra, "ties": sorted(set(ties)), "confused": confused,
            "named": [f.effect.name for f in findings]}


def truth_named(diagnosis, case: Case) -> dict[str, str]:
    """How the diagnosis named each true effect of the case: "chosen" (a cause or found on top),
    "tied" (tied with a chosen effect), "finding" (a finding not chosen), or "missing"."""
    chosen = {f.effect.name for f in diagnosis.chosen}
    tied = {n for f in diagnosis.chosen for n in f.tied_with}
    found = {f.effect.name for f in diagnosis.findings}
    return {n: "chosen" if n in chosen else "tied" if n in tied else "finding" if n in found else "missing"
            for n in case.truth}


__all__ = ["CASES", "BY_NAME", "Case", "FAMILY", "GENERATORS", "make_case_log", "score", "truth_named"]
