"""What a log determines: 95 % intervals of fitted parameters, which of them the log determines,
and which it says must change.

Intervals. The residuals of a window fit are not independent draws: the components of one window
share its start state, and neighbouring windows of one log share the robot's state and the
simulator's errors. The covariance is therefore the cluster-robust sandwich
A^-1 (sum_g s_g s_g^T) A^-1 G / (G - 1), A = J^T J, s_g = J_g^T r_g the score of cluster g (a few
consecutive windows, :func:`clusters`), with Student's t at G - 1 degrees of freedom. The
simulator's own error does not average out over windows, so each interval also carries the
*model-form shift* of every parameter: the change of the fitted value that replacing the fit's
simulator by a better one would cause, linearised as A^-1 J^T (r_better - r) (:class:`ModelFormSource`;
the sources are measured by :func:`mjtrack.calibrate.run.calibrate`). Half-width
t sd + |shift| (a bias does not shrink with more windows, so it is added, not put in quadrature).

What the log determines. A parameter is determined when its half-width is at most its resolution
(:attr:`mjtrack.calibrate.params.ParamSpec.resolution`) or at most its distance from the
described value (the interval then excludes the description: the log says it must change, and the
interval says by how much). :func:`select` removes, one at a time, the parameter whose half-width
is the largest multiple of that allowance and recomputes the
others' intervals without it (the sandwich of the remaining columns); a parameter removed because
it trades with another (|correlation| above :data:`TIE`) leaves that one to carry their
combination, and both are reported as not determined one by one. Then, among the determined
ones, the parameter whose described value lies deepest inside its interval goes back to that
value (the others follow the linearised least-squares optimum), until every remaining parameter
differs from its description by more than its half-width: a log on which nothing needs to change
changes nothing.

Defaults are not information. A parameter the log does not determine goes back to its described
value, and the others' intervals are then conditional on it. Where the description gives that
value, the condition is the user's own statement. Where it does not, the value is a default and the
condition an assumption, so :func:`final_verdicts` gives the kept parameters the wider of their
conditional half-widths and those with the defaulted parameters fitted too (marginal over what the
log allows them). Two descriptions that differ only in such defaults then give intervals that
allow for each other's answer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjtrack.calibrate.params import ParamSpec
from mjtrack.stats import cluster_sandwich, gram_inverse, t_quantile

TIE = 0.9  # |correlation| above which a parameter removed as undetermined trades with the other
EIG_FLOOR = 1e-12  # eigenvalues of A below this share of the largest count as zero (infinite variance)
WIDER = 1e-3  # a half-width that allowing for held defaults widens by less than this share is kept as it was
CLUSTER_WINDOWS = 3  # consecutive windows per cluster (fewer when the log has few windows per parameter)


def clusters(n_windows: int, n_params: int) -> np.ndarray:
    """Cluster label (M,) of each window: consecutive groups of :data:`CLUSTER_WINDOWS` windows,
    smaller groups when there would be fewer than three clusters per parameter."""
    size = max(1, min(CLUSTER_WINDOWS, n_windows // max(1, 3 * n_params)))
    return np.arange(n_windows) // size


@dataclass(frozen=True)
class ModelFormSource:
    """A model-form source: its name and g = J^T (r_better - r) (n,) in scaled units."""

    name: str
    g: np.ndarray


@dataclass
class Linearised:
    """The fit linearised at its optimum, for any subset of its parameters.

    Attributes:
        names: the fitted parameters (columns of ``jac``).
        theta: (n,) fitted values, scaled (units of each spec's ``scale``).
        jac: (R, n) Jacobian of the residuals, scaled columns.
        resid: (R,) residuals at ``theta``.
        rows_per_window: residual components per window (window-major rows).
        specs: every parameter's spec.
        model_form: the model-form sources.
        floors: parameter -> the least half-width the simulator allows it (a time constant or a
            dead time is resolved to one time step at best: a lag of 2 ms and none differ by less
            than the step's own discretisation).
    """

    names: list[str]
    theta: np.ndarray
    jac: np.ndarray
    resid: np.ndarray
    rows_per_window: int
    specs: dict[str, ParamSpec]
    model_form: list[ModelFormSource] = field(default_factory=list)
    floors: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.A = self.jac.T @ self.jac
        self.scales = np.array([self.specs[n].scale for n in self.names])
        self.M = self.resid.size // self.rows_per_window

    def step(self, idx: list[int] | None = None) -> np.ndarray:
        """The Gauss-Newton step (n,) from ``theta`` to the linearised optimum of the parameters
        ``idx`` (default all), the others held; a parameter on a bound that the gradient pushes
        outwards stays there (0 in the step). Zero where the optimiser converged."""
        idx = list(range(len(self.names))) if idx is None else list(idx)
        lo = np.array([self.specs[n].lo for n in self.names]) / self.scales
        hi = np.array([self.specs[n].hi for n in self.names]) / self.scales
        grad = self.jac.T @ self.resid  # half the gradient of the cost
        act = list(idx)
        for _ in range(len(idx) + 1):
            out = np.zeros(len(self.names))
            if act:
                out[act] = -np.linalg.lstsq(self.A[np.ix_(act, act)], grad[act], rcond=None)[0]
            stuck = [i for i in act if (self.theta[i] + out[i] < lo[i] and self.theta[i] - lo[i] <= 1e-9 * max(1.0, abs(lo[i])))
                     or (self.theta[i] + out[i] > hi[i] and hi[i] - self.theta[i] <= 1e-9 * max(1.0, abs(hi[i])))]
            if not stuck:
                break
            act = [i for i in act if i not in stuck]
        return np.clip(self.theta + out, lo, hi) - self.theta

    def advance(self) -> np.ndarray:
        """Move ``theta`` and ``resid`` to the linearised optimum (:meth:`step`); returns the step."""
        d = self.step()
        self.theta = self.theta + d
        self.resid = self.resid + self.jac @ d
        return d

    def uncertainty(self, idx: list[int], resid: np.ndarray | None = None) -> "Uncertainty":
        """Intervals of the parameters ``idx`` (positions in ``names``) with the others held."""
        r = self.resid if resid is None else resid
        J = self.jac[:, idx]
        Ainv = gram_inverse(J, eig_floor=EIG_FLOOR)
        lab = clusters(self.M, len(idx))
        G = int(lab.max()) + 1
        cov = cluster_sandwich(J, r, np.repeat(lab, self.rows_per_window), eig_floor=EIG_FLOOR)
        sd = np.sqrt(np.diag(cov))
        shifts = np.array([Ainv @ m.g[idx] for m in self.model_form]).reshape(len(self.model_form), len(idx))
        shift = np.sqrt(np.sum(shifts ** 2, axis=0)) if len(self.model_form) else np.zeros(len(idx))
        t = t_quantile(G)
        corr = cov / np.maximum(np.outer(sd, sd), 1e-300)
        sc = self.scales[idx]
        floor = np.array([self.floors.get(self.names[i], 0.0) for i in idx])
        return Uncertainty(names=[self.names[i] for i in idx], sd=sd * sc, shift=shift * sc,
                           half=np.maximum((t * sd + shift) * sc, floor), corr=corr, clusters=G, t=t,
                           shifts={m.name: s * sc for m, s in zip(self.model_form, shifts)})


@dataclass(frozen=True)
class Uncertainty:
    """Intervals of a set of parameters (physical units): ``sd`` statistical standard deviation,
    ``shift`` model-form shift, ``half`` 95 % half-width, ``corr`` correlations of the statistical
    part, ``clusters`` their number, ``t`` the quantile used, ``shifts`` each source's shift."""

    names: list[str]
    sd: np.ndarray
    shift: np.ndarray
    half: np.ndarray
    corr: np.ndarray
    clusters: int
    t: float
    shifts: dict[str, np.ndarray]


@dataclass
class Verdict:
    """What the log says of one parameter the fit was allowed to move."""

    name: str
    determined: bool
    changed: bool
    value: float
    described: float
    interval: tuple[float, float] | None
    reason: str
    tied_with: list[str] = field(default_factory=list)
    #: the value the log points at when the fit's rounds ran out before reaching it (the parameter
    #: then keeps its described value, which the log does not confirm)
    points_at: float | None = None
    #: the fit's rounds ran out while its last decision would send this fitted parameter back to its
    #: described value: the value is the last fit's, which the decisions did not settle on
    unsettled: bool = False
    #: parameters held at a default (not in the description, not determined by the log) that the
    #: interval allows for (:func:`final_verdicts`)
    allows_for: list[str] = field(default_factory=list)

    def to_json(self) -> dict:
        out = {"determined": bool(self.determined), "changed": bool(self.changed), "reason": self.reason}
        if self.tied_with:
            out["tied_with"] = list(self.tied_with)
        if self.points_at is not None:
            out["points_at"] = float(self.points_at)
        if self.unsettled:
            out["unsettled"] = True
        if self.allows_for:
            out["allows_for"] = list(self.allows_for)
        return out


def fmt_value(v: float, unit: str) -> str:
    return f"{v:.3g} {unit}" if unit not in ("–", "-") else f"{v:.3g}"


@dataclass
class Selection:
    """The outcome of :func:`select`: the parameters to keep fitting (``free``) and their linearised
    values (physical), the verdicts of the others so far."""

    free: list[str]
    values: dict[str, float]
    verdicts: dict[str, Verdict]
    ties: dict[str, list[str]]


def allowance(resolution, distance):
    """The widest 95 % half-width at which a parameter counts as determined: its resolution, or its
    distance from the described value (the interval then excludes the description)."""
    return np.maximum(resolution, distance)


def select(lin: Linearised, described: dict[str, float]) -> Selection:
    """Remove what the log does not determine, then what it does not need changed (module docstring)."""
    specs = lin.specs
    idx = list(range(len(lin.names)))
    theta = lin.theta.copy()
    resid = lin.resid.copy()
    verdicts: dict[str, Verdict] = {}
    ties: dict[str, list[str]] = {}
    res = np.array([specs[n].resolution for n in lin.names])
    d_scaled = np.array([described[n] / specs[n].scale for n in lin.names])

    def revert(i: int) -> None:
        """Set parameter i to its described value; the free ones follow the linearised optimum."""
        nonlocal theta, resid
        rest = [k for k in idx if k != i]
        step = d_scaled[i] - theta[i]
        A = lin.A
        if rest:
            dr = -np.linalg.lstsq(A[np.ix_(rest, rest)], A[rest, i] * step, rcond=None)[0]
            theta[rest] += dr
            resid = resid + lin.jac[:, rest] @ dr
        resid = resid + lin.jac[:, i] * step
        theta[i] = d_scaled[i]

    # 1. what the log determines
    while idx:
        u = lin.uncertainty(idx, resid)
        # determined: the interval is within the resolution, or narrow enough to exclude the
        # description (the log then says the value must change, and by about how much)
        ratio = u.half / allowance(res[idx], np.abs(theta[idx] - d_scaled[idx]) * lin.scales[idx])
        k = int(np.argmax(ratio))
        if ratio[k] <= 1.0:
            break
        i = idx[k]
        name = lin.names[i]
        spec = specs[name]
        partners = [(idx[j], float(u.corr[k, j])) for j in range(len(idx)) if j != k and abs(u.corr[k, j]) > TIE]
        if partners:
            j, c = max(partners, key=lambda p: abs(p[1]))
            other = lin.names[j]
            reason = (f"trades with {other} (correlation {c:+.2f}): the log determines their combination, not "
                      f"each one; {name} stays at its described value {fmt_value(described[name], spec.unit)} and "
                      f"{other} carries the combination")
            ties.setdefault(other, []).append(name)
            tied = [other]
        else:
            reason = (f"not determined by this log: its 95 % interval would be +-{fmt_value(u.half[k], spec.unit)}, "
                      f"wider than the +-{fmt_value(spec.resolution, spec.unit)} that matters and than its distance "
                      f"from the description; it stays at its "
                      f"described value {fmt_value(described[name], spec.unit)}")
            tied = []
        verdicts[name] = Verdict(name, False, False, described[name], described[name], None, reason, tied)
        revert(i)
        idx.remove(i)

    # 2. what the log says must change
    while idx:
        u = lin.uncertainty(idx, resid)
        z = np.abs(theta[idx] - d_scaled[idx]) * lin.scales[idx] / np.maximum(u.half, 1e-300)
        k = int(np.argmin(z))
        if z[k] > 1.0:
            break
        i = idx[k]
        name = lin.names[i]
        spec = specs[name]
        v = theta[i] * spec.scale
        lo, hi = max(spec.lo, v - u.half[k]), min(spec.hi, v + u.half[k])
        verdicts[name] = Verdict(name, name not in ties, False, described[name], described[name], (lo, hi),
                                 f"consistent with the description: {fmt_value(described[name], spec.unit)} lies in the "
                                 f"95 % interval [{lo:.4g}, {hi:.4g}] of the fit; kept", ties.get(name, []))
        revert(i)
        idx.remove(i)
    free = [lin.names[i] for i in idx]
    for v in verdicts.values():  # a tie whose carrier went back to its description: neither moves
        if v.tied_with and v.tied_with[0] not in free and "carries the combination" in v.reason:
            v.reason = v.reason.replace(f"and {v.tied_with[0]} carries the combination",
                                        f"and so does {v.tied_with[0]}: their combination needs no change")
    return Selection(free=free, values={lin.names[i]: float(theta[i] * lin.scales[i]) for i in range(len(lin.names))},
                     verdicts=verdicts, ties={k: v for k, v in ties.items() if k in free})


def final_verdicts(lin: Linearised, described: dict[str, float], ties: dict[str, list[str]],
                   allow_for: tuple[list[str], np.ndarray] | None = None
                   ) -> tuple[dict[str, Verdict], Uncertainty, np.ndarray]:
    """Verdicts of the parameters still fitted, at the final fit (``lin``), and their uncertainty.
    Where the optimiser stopped short of the linearised optimum, the remaining step is added to
    each half-width (returned, physical units, as the third value). ``allow_for``: parameters held
    at a default the log does not confirm, and the half-widths (physical) of ``lin``'s parameters
    with those fitted too; a half-width is the wider of the two (module docstring)."""
    u = lin.uncertainty(list(range(len(lin.names))))
    rest = np.abs(lin.step()) * lin.scales
    out = {}
    for k, name in enumerate(lin.names):
        spec = lin.specs[name]
        v = float(lin.theta[k] * spec.scale)
        half = float(u.half[k] + rest[k])
        widened = allow_for is not None and allow_for[1][k] > u.half[k] * (1 + WIDER)
        if widened:
            half = float(allow_for[1][k] + rest[k])
        lo, hi = max(spec.lo, v - half), min(spec.hi, v + half)
        tied = ties.get(name, [])
        changed = has_changed(v, described[name])
        allow = float(allowance(spec.resolution, abs(v - described[name])))
        if tied:
            reason = (f"carries its combination with {', '.join(tied)}, which the log cannot tell apart: "
                      f"{fmt_value(v, spec.unit)} [{lo:.4g}, {hi:.4g}] holds only with "
                      f"{', '.join(tied)} at the described value")
        elif half > allow:
            reason = (f"moved but barely determined: 95 % interval +-{fmt_value(half, spec.unit)} is wider than the "
                      f"+-{fmt_value(spec.resolution, spec.unit)} that matters and reaches the described value")
        else:
            unit = "" if spec.unit in ("–", "-") else f" {spec.unit}"
            reason = (f"determined: 95 % interval [{lo:.4g}, {hi:.4g}]{unit} (statistical "
                      f"+-{fmt_value(u.t * u.sd[k], spec.unit)} over {u.clusters} clusters of windows, model form "
                      f"+-{fmt_value(u.shift[k], spec.unit)}, optimiser +-{fmt_value(rest[k], spec.unit)})")
            if not changed:
                reason += "; equal to the description"
        if widened:
            reason += (f"; the interval allows for {', '.join(allow_for[0])}, which the description does not give and "
                       f"the log does not determine (+-{fmt_value(u.half[k], spec.unit)} with "
                       f"{'them' if len(allow_for[0]) > 1 else 'it'} held at the default)")
        edge = spec.hi if v >= spec.hi - 1e-9 * max(1.0, abs(spec.hi)) else (
            spec.lo if v <= spec.lo + 1e-9 * max(1.0, abs(spec.lo)) else None)
        if edge is not None:  # the fit stopped at the range searched: the log may want more, the interval is cut
            reason += (f"; at the edge of the range searched ({fmt_value(edge, spec.unit)}): the log may point "
                       "beyond it, and the interval stops there")
        out[name] = Verdict(name, bool(not tied and half <= allow), changed, v, described[name], (lo, hi),
                            reason, tied, allows_for=list(allow_for[0]) if widened else [])
    return out, u, rest


def has_changed(value: float, described: float) -> bool:
    return not math.isclose(value, described, rel_tol=1e-12, abs_tol=1e-15)


__all__ = ["Linearised", "ModelFormSource", "Selection", "Uncertainty", "Verdict", "clusters", "final_verdicts",
           "select"]
