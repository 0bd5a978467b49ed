"""Command-line pieces shared by the commands: option bounds, robot options, ``--quiet``,
``--force``, ``--out`` checks.

Every numeric option is bounded at parsing, before any work, by :data:`OPTION_BOUNDS` (one table:
speeds and robot values reuse the plausibility limits of the drive-log and robot readers); a value
outside is a usage error, exit 2, one line naming the option, its value and the range.

Overwrites, one rule for every command: an output that already exists is not replaced unless
``--force`` is given, and an output that is one of the command's inputs (:func:`command_inputs`)
is never replaced, not even with ``--force`` (exit 2, one line naming the file, before any work;
:func:`check_overwrite`). The inputs are read before the outputs are checked, so that an error in
the robot file is reported before a clash of names. :class:`mjtrack.io.atomic.OutputTransaction` guards the same rule
when the files are written.

Robot options on every command that simulates::

    --robot FILE  --cg-x M  --cg-y M  --mu X  --mu-left X  --mu-right X  --mass KG
    --track-gauge M  --track-length M  --wheelbase M

:func:`robot_from_args` builds the :class:`~mjtrack.io.robot.Robot`: the ``--robot`` file if
given, else the caller's ``base`` (a scenario's robot, a log's ``LOG.json``), else the default
robot; then each option given on the command line replaces that field. The result is validated
as a whole, so ``--cg-y 0.3`` with a 0.4 m gauge is refused (centre of mass outside the tracks).

``--out`` checks run before any long work, so that a run does not fail at the very end
because its output cannot be written. They do not create anything; outputs are written
atomically by :mod:`mjtrack.io.atomic`.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import tempfile
from pathlib import Path
from typing import Iterable

from dataclasses import dataclass

from mjtrack.errors import InputError
from mjtrack.io.logs import PLAUSIBLE, read_log, read_log_with_robot, robot_path_for
from mjtrack.io.robot import PLAUSIBLE_ROBOT, Robot, read_robot

#: library parameter -> command-line option. The library's errors name the parameters of its
#: functions (``params: ...``, ``workers=64: ...``, ``pass force=True``, ``settle_s``); the command
#: line shows them as its options (:func:`option_words`), one mapping for every command.
PARAMETER_OPTIONS: dict[str, str] = {
    "params": "--params", "terrain": "--terrain", "settle_s": "--settle", "window_s": "--window",
    "horizon_s": "--horizon", "workers": "--workers", "scheduler": "--scheduler", "baseline": "--baseline",
    "force": "--force", "restart": "--force", "drive_input": "--drive-input", "odom": "--odom", "cmd": "--cmd",
    "joints": "--joints", "robot_path": "--robot", "out": "--out", "keep_contradicting": "--keep-contradicting",
    "fit_windows": "--fit-windows", "n_folds": "--folds", "rounds": "--rounds",
}
_NAMES = "|".join(sorted(PARAMETER_OPTIONS, key=len, reverse=True))
_LEADING = re.compile(rf"^({_NAMES}):")  # "params: unknown parameter 'x'"
_FLAG = re.compile(rf"\b({_NAMES})=True\b")  # "pass force=True"
_VALUE = re.compile(rf"\b({_NAMES})=('[^']*'|\"[^\"]*\"|[^\s:;,)]+)")  # "workers=64", "terrain='step:1:2'"
_SNAKE = re.compile(rf"\b({'|'.join(n for n in PARAMETER_OPTIONS if '_' in n)})\b")  # "settle_s", "horizon_s"


def option_words(message: str) -> str:
    """A library error's ``message`` with its parameters written as the command line's options
    (:data:`PARAMETER_OPTIONS`): a leading ``name:``, ``name=True`` (a flag), ``name=value`` (the
    option and its value, quotes dropped) and any parameter name with an underscore."""
    message = _LEADING.sub(lambda m: PARAMETER_OPTIONS[m[1]] + ":", message)
    message = _FLAG.sub(lambda m: PARAMETER_OPTIONS[m[1]], message)
    message = _VALUE.sub(lambda m: f"{PARAMETER_OPTIONS[m[1]]} {m[2].strip(chr(39) + chr(34))}", message)
    return _SNAKE.sub(lambda m: PARAMETER_OPTIONS[m[1]], message)


# option dest -> (Robot field, metavar, help)
ROBOT_OPTIONS: dict[str, tuple[str, str, str]] = {
    "cg_x": ("cg_x", "M", "centre of mass ahead (+) / behind (-) the geometric centre [m]"),
    "cg_y": ("cg_y", "M", "centre of mass left (+) / right (-) of the geometric centre [m]"),
    "mu": ("mu", "X", "ground friction coefficient, both tracks [-]"),
    "mu_left": ("mu_left", "X", "ground friction coefficient of the left track (overrides --mu there) [-]"),
    "mu_right": ("mu_right", "X", "ground friction coefficient of the right track (overrides --mu there) [-]"),
    "mass": ("mass", "KG", "total mass [kg]"),
    "track_gauge": ("track_gauge", "M", "distance between the track centre lines [m]"),
    "track_length": ("track_length", "M", "length of each track's ground contact [m]"),
    "wheelbase": ("wheelbase", "M", "front to rear axle distance of a wheeled robot [m]"),
}


# the bounds that depend on the rest of the robot, as its check states them (io/robot.py)
ROBOT_BOUND_TEXT = {
    "cg_x": "|cg_x| < track_length/2 (wheelbase/2 on wheels)",
    "cg_y": "|cg_y| < track_gauge/2",
}


@dataclass(frozen=True)
class Bound:
    """The allowed range of an option: low <= value <= high (low < value when ``low_open``)."""

    low: float
    high: float
    unit: str
    what: str
    low_open: bool = False
    integer: bool = False
    even: bool = False

    def text(self) -> str:
        lo = "(" if self.low_open else "["
        return f"{lo}{self.low:g}, {self.high:g}]{' ' + self.unit if self.unit else ''}"


_SPEED = PLAUSIBLE["v_left_cmd"][0]  # [m/s] the drive-log bound of a track speed
# [m] half the longest plausible track or gauge: no centre-of-mass offset can be larger (the robot's
# own bound, checked with the rest of the robot, is |cg_x| < track_length/2, |cg_y| < track_gauge/2)
_COORD = PLAUSIBLE_ROBOT["track_length"][1] / 2
DAY_S = 86_400.0  # [s] longest simulated time an option takes (the rollout's step budget still applies)

#: kind -> bound; the one table behind every numeric option of every command
OPTION_BOUNDS: dict[str, Bound] = {
    "speed": Bound(-_SPEED, _SPEED, "m/s", "a track speed (the drive-log bound)"),
    "reference_speed": Bound(0.0, _SPEED, "m/s", "a reference speed", low_open=True),
    "duration": Bound(0.0, DAY_S, "s", "a simulated time", low_open=True),
    "settle": Bound(0.0, DAY_S, "s", "a settling time"),
    "window": Bound(0.0, DAY_S, "s", "an averaging window", low_open=True),
    "horizon": Bound(0.0, 60.0, "s", "a prediction horizon", low_open=True),  # 48 windows of 60 s: ~0.7 GB a rollout call
    "timestep": Bound(1e-5, 0.05, "s", "a simulation time step"),
    "log_rate": Bound(0.0, 10_000.0, "Hz", "a log rate", low_open=True),
    "control_rate": Bound(0.0, 1_000.0, "Hz", "a control rate", low_open=True),
    "laps": Bound(0.0, 1_000.0, "", "laps", low_open=True),
    "seed": Bound(0, 2**32 - 1, "", "a seed", integer=True),
    "noise_scale": Bound(0.0, 100.0, "", "a noise scale"),
    "fps": Bound(0.0, 240.0, "frames/s", "a frame rate", low_open=True),
    "playback": Bound(0.01, 1_000.0, "", "a playback speed"),
    "width": Bound(16, 7680, "px", "an even image width", integer=True, even=True),
    "height": Bound(16, 4320, "px", "an even image height", integer=True, even=True),
    "folds": Bound(3, 1_000, "", "a number of folds", integer=True),
    "iterations": Bound(1, 1_000, "", "a number of iterations", integer=True),
    "rounds": Bound(0, 20, "", "a number of rounds", integer=True),  # = calibrate.rounds.MAX_ROUNDS_LIMIT (a test holds it)
    "rollers": Bound(2, 200, "", "rollers per track", integer=True),  # a robot file's simulator n_rollers too
    "threads": Bound(1, 64, "", "a number of threads", integer=True),
    "fit_windows": Bound(5, 1_000_000, "", "a number of windows", integer=True),
    "workers": Bound(1, 64, "", "a number of worker processes", integer=True),
    # robot options: the robot reader's plausibility table
    **{name: Bound(lo, hi, "" if unit == "-" else unit, f"a robot's {name}", low_open=lo == 0.0)
       for name, (lo, hi, unit) in PLAUSIBLE_ROBOT.items()},
    "cg_x": Bound(-_COORD, _COORD, "m", "a centre-of-mass offset"),
    "cg_y": Bound(-_COORD, _COORD, "m", "a centre-of-mass offset"),
}


def bounded(kind: str, words: dict | None = None):
    """argparse ``type=``: a number within ``OPTION_BOUNDS[kind]`` (else a usage error, exit 2,
    naming the value and the range; argparse adds the option's name); ``words``: texts accepted
    instead of a number, and their values (``{"all": None}``)."""
    bound = OPTION_BOUNDS[kind]

    def parse(text: str):
        if words and text.strip().lower() in words:
            return words[text.strip().lower()]
        if bound.integer:
            try:
                value = int(text)
            except ValueError:
                raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        else:
            value = finite_float(text)
        below = value <= bound.low if bound.low_open else value < bound.low
        if below or value > bound.high or (bound.even and value % 2):
            raise argparse.ArgumentTypeError(f"{text} is out of range: {bound.what} in {bound.text()}")
        return value

    parse.__name__ = kind  # argparse names the type in some messages
    return parse


def finite_float(text: str) -> float:
    """argparse ``type=``: a finite float (``nan``/``inf`` are usage errors, exit 2)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def add_robot_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--robot FILE`` and the per-field overrides (all default to ``None``: not given)."""
    group = parser.add_argument_group(
        "robot", "the robot: --robot FILE (a JSON object of SI values: track_gauge [m, required], track_length, "
        "track_width, sprocket_radius [m], mass [kg], cg_x, cg_y [m] (from the geometric centre), cg_z [m] (height "
        "above the ground), mu, mu_left, mu_right; a wheeled robot: "
        "traction \"wheels\", wheel_radius, wheelbase [m], wheels_per_side), then each option below overrides one field"
    )
    group.add_argument("--robot", metavar="FILE", type=Path, default=None,
                       help="robot description JSON (at least 'track_gauge' [m])")
    for dest, (_, metavar, text) in ROBOT_OPTIONS.items():
        bound = ROBOT_BOUND_TEXT.get(dest, f"in {OPTION_BOUNDS[dest].text()}")
        group.add_argument("--" + dest.replace("_", "-"), dest=dest, metavar=metavar,
                           type=bounded(dest), default=None, help=f"{text}, {bound}")


def robot_from_args(args: argparse.Namespace, base: Robot | None = None) -> Robot:
    """The robot the command line asks for.

    Start from ``--robot FILE`` (wins over ``base``), else ``base``, else ``Robot()``; replace
    every field whose option was given. Invalid values or combinations raise
    :class:`InputError` (one line, naming the options and file that were given).
    """
    path = getattr(args, "robot", None)
    robot = read_robot(path) if path is not None else (base if base is not None else Robot())
    changes = {
        field: float(getattr(args, dest))
        for dest, (field, _, _) in ROBOT_OPTIONS.items()
        if getattr(args, dest, None) is not None
    }
    if not changes:
        return robot
    try:
        return robot.replace(**changes)
    except InputError as exc:
        given = " ".join(
            f"--{dest.replace('_', '-')} {getattr(args, dest)}"
            for dest in ROBOT_OPTIONS
            if getattr(args, dest, None) is not None
        )
        origin = f" on top of {path}" if path is not None else ""
        raise InputError(f"{exc} (options: {given}{origin})") from None


TERRAIN_HELP = ("terrain under the simulated robot: flat, incline:ANGLE[:DIR] (rad; DIR the uphill "
                "direction, default 0 = +x), step:HEIGHT:X (a step across the ground from x = X on), "
                "hfield:FILE:SIZE_X:SIZE_Y:HEIGHT (.npy or .png heights scaled 0-1, centred at the origin), "
                "patches:FILE.json (rectangles {x, y, size_x, size_y, mu}) or FILE.json combining "
                "incline/steps/hfield/patches")


def add_terrain_option(parser: argparse.ArgumentParser, *, scenarios: bool = True) -> None:
    """Add ``--terrain SPEC`` (parsed by :func:`terrain_from_args`); ``scenarios``: the command
    also takes ``--scenario``, whose terrain is the default."""
    default = "the scenario's terrain, else flat" if scenarios else "flat ground"
    parser.add_argument("--terrain", metavar="SPEC", default=None, help=f"{TERRAIN_HELP} (default: {default})")


def scenario_help(lead: str) -> str:
    """``lead`` and every built-in scenario with what it drives (the ``--scenario`` help)."""
    from mjtrack.sim.scenarios import SCENARIOS

    return f"{lead}: " + "; ".join(f"{s.name}: {s.description} ({s.duration:g} s)" for s in SCENARIOS.values())


def terrain_from_args(args: argparse.Namespace, scenario: str | None = None):
    """The :class:`~mjtrack.sim.terrain.Terrain` of ``--terrain``, else the scenario's, else flat
    (bad specs: InputError)."""
    from mjtrack.sim.scenarios import SCENARIOS
    from mjtrack.sim.terrain import Terrain, parse_terrain

    spec = getattr(args, "terrain", None)
    if spec is not None:
        return parse_terrain(spec)
    return SCENARIOS[scenario].terrain if scenario in SCENARIOS else Terrain()


def add_output_options(parser: argparse.ArgumentParser, *, force: bool = True) -> None:
    """Add ``-q/--quiet`` (no progress display) and, unless ``force`` is False, ``--force``."""
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress display (it is also off when stderr is not a terminal)")
    if force:
        add_force_option(parser)


FORCE_HELP = ("replace outputs that already exist (without it an existing output is refused: exit 2, "
              "nothing written)")


def add_force_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--force`` (replace existing outputs; :func:`check_overwrite`)."""
    parser.add_argument("--force", action="store_true", help=FORCE_HELP)


def check_overwrite(paths: Iterable[str | os.PathLike], force: bool,
                    inputs: Iterable[str | os.PathLike] = ()) -> None:
    """Refuse, before any work, to replace any of ``paths`` that is one of ``inputs`` (even with
    ``force``: a user's robot file or log is never replaced by an output), or that exists, unless
    ``force``."""
    paths = [Path(p) for p in paths]
    inputs = [Path(p) for p in inputs]
    for path in paths:
        for other in inputs:
            if _same_file(path, other):
                raise InputError(f"{path}: is an input of this command ({other}); an output never replaces "
                                 "an input, not even with --force: choose another output name")
    if force:
        return
    for path in paths:
        if os.path.lexists(path):
            raise InputError(f"{path}: exists; pass --force to replace it")


def _same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` name one file (the same path, a link to it, or a hard link)."""
    if a.absolute() == b.absolute() or a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist
        return False


# options that name files a command reads
_INPUT_OPTIONS = ("robot", "log", "test", "commands", "grid", "bag")


def robot_config(robot: Robot):
    """The simulator settings a robot file records under ``simulator`` (what a calibrated robot was
    fitted with; :func:`mjtrack.sim.config.sim_config`), else the defaults: every command that
    simulates a robot file's robot simulates it as it was calibrated."""
    from mjtrack.sim.config import sim_config

    return sim_config(None, robot=robot)


def check_robot_file(args: argparse.Namespace) -> None:
    """Read ``--robot FILE`` when given, so that an error in it is reported before the outputs are
    checked (for commands that build their robot only later, after a rollout's work estimate)."""
    if getattr(args, "robot", None) is not None:
        read_robot(args.robot)


def command_inputs(args: argparse.Namespace) -> list[Path]:
    """The files a command reads: the input options' files, the robot description beside a log
    (``LOG.json``, read when no ``--robot`` is given) and a ``--terrain`` file."""
    paths = []
    for name in _INPUT_OPTIONS:
        value = getattr(args, name, None)
        if isinstance(value, (str, os.PathLike)):
            paths.append(Path(value))
            if name in ("log", "test"):
                paths.append(robot_path_for(value))
    spec = getattr(args, "terrain", None)
    if isinstance(spec, str):
        kind, _, rest = spec.partition(":")
        if kind in ("hfield", "patches") and rest:
            paths.append(Path(rest.split(":")[0]))
        elif spec.endswith(".json"):
            paths.append(Path(spec))
    return paths


_TMP_EXTRA = 16  # characters atomic writes add to a name (".NAME.xxxxxxxx.tmp")


def _probe(folder: Path, path: Path, what: str) -> None:
    """Refuse unless a file can really be created in ``folder`` (created and removed at once):
    ``os.access`` says yes to root on any folder and knows nothing of full disks or quotas."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".mjtrack-probe.", dir=folder)
    except OSError as exc:
        raise InputError(f"{path}: cannot create {what}: {folder} is not writable ({exc.strerror})") from None
    os.close(fd)
    os.unlink(tmp)


def _check_names(path: Path, what: str) -> None:
    """Refuse names the file system will not take (too long), before any work."""
    for part in path.parts:
        if len(os.fsencode(part)) + _TMP_EXTRA > 255:
            raise InputError(f"{path}: cannot create {what}: the name {part[:20]}... is too long")
    if len(os.fsencode(str(path.absolute()))) + _TMP_EXTRA > 4095:
        raise InputError(f"{path}: cannot create {what}: the path is too long")


def _writable_ancestor(path: Path, what: str) -> None:
    """Refuse ``path`` if the nearest existing ancestor is not a writable folder."""
    _check_names(path, what)
    for parent in path.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{path}: cannot create {what}: {parent} is not a folder")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise InputError(f"{path}: cannot create {what}: {parent} is not writable")
            _probe(parent, path, what)
            return
    raise InputError(f"{path}: cannot create {what}: no existing parent folder")  # pragma: no cover


def check_out_dir(path: str | os.PathLike) -> Path:
    """Check an ``--out DIR`` before the work: an existing writable folder, or creatable."""
    path = Path(path)
    _check_names(path, "output folder")
    if path.exists():
        if not path.is_dir():
            raise InputError(f"{path}: --out must be a folder, this is an existing file")
        if not os.access(path, os.W_OK | os.X_OK):
            raise InputError(f"{path}: --out folder is not writable")
        _probe(path, path, "files in the output folder")
        return path
    _writable_ancestor(path, "output folder")
    return path


def check_out_file(
    path: str | os.PathLike, *, suffixes: Iterable[str] = (), inputs: Iterable[str | os.PathLike] = ()
) -> Path:
    """Check an ``--out FILE`` before the work.

    Refused: a name without one of ``suffixes`` (case-insensitive, when given), an existing
    folder, a file that would overwrite one of ``inputs``, a parent that cannot be created
    or written.
    """
    path = Path(path)
    _check_names(path, "output file")
    suffixes = tuple(s.lower() for s in suffixes)
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"{path}: --out must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise InputError(f"{path}: --out is an existing folder, expected a file name")
    for other in inputs:
        if _same_file(path, Path(other)):
            raise InputError(f"{path}: --out would overwrite the input {other}")
    if path.parent.exists():
        if not path.parent.is_dir():
            raise InputError(f"{path}: cannot create output file: {path.parent} is not a folder")
        if not os.access(path.parent, os.W_OK | os.X_OK):
            raise InputError(f"{path}: cannot create output file: {path.parent} is not writable")
        _probe(path.parent, path, "output file")
    else:
        _writable_ancestor(path.parent, "output file")
    return path


def log_and_robot(args: argparse.Namespace):
    """The drive log ``args.log`` and its robot: ``--robot FILE`` when given, else the log's
    own ``LOG.json`` (:func:`mjtrack.io.logs.read_log_with_robot`, the one way a log's robot is
    found), with the robot options on top."""
    log, base = read_log_with_robot(args.log, args.robot)
    return log, robot_from_args(args, base)


def test_log_and_robot(path: Path | None):
    """A held-out log (``--test LOG2``) and the robot its own ``LOG2.json`` describes (None
    without one); (None, None) when no test log was given."""
    if path is None:
        return None, None
    robot_path = robot_path_for(path)
    return read_log(path), (read_robot(robot_path) if robot_path.exists() else None)
