"""Terrain under the MuJoCo robot: ``--terrain SPEC`` parsed, checked and added to a model.

Specs (SI units, angles in radians):

* ``flat`` (default): the ground plane z = 0.
* ``incline:ANGLE[:DIR]``: the ground plane tilted by ANGLE, rising along the world direction DIR
  (default 0 = +x). Every other terrain element lies on this tilted ground.
* ``step:HEIGHT:X``: a step of HEIGHT across the ground from ground x = X on (a box 100 m deep).
* ``hfield:FILE:SIZE_X:SIZE_Y:HEIGHT``: a height field from FILE (``.npy``: a 2-D array, or
  ``.png``: grey levels), heights scaled to 0-1 over the file's range (a constant field is 0),
  times HEIGHT [m], SIZE_X x SIZE_Y metres centred at the origin; row 0 is at -y (MuJoCo's
  convention).
* ``patches:FILE.json``: rectangles with their own friction, ``{"patches": [{"x": CX, "y": CY,
  "size_x": SX, "size_y": SY, "mu": MU}, ...]}`` (centre and full size [m] in ground
  coordinates): 1 mm thick boxes lying on the ground.
* ``FILE.json`` combining them: ``{"incline": {"angle": A, "direction": D}, "steps": [{"height":
  H, "x": X}], "hfield": {"file": F, "size_x": SX, "size_y": SY, "height": H}, "patches": [...]}``
  (every key optional; relative file names are relative to the JSON file).

Initial pose: the robot starts at the origin, heading +x, its frame aligned with the (tilted)
ground, raised to the highest terrain point under its footprint (then settles).

Size: a terrain JSON file is at most :data:`MAX_JSON_BYTES` and nested at most
:data:`MAX_JSON_DEPTH` deep; at most :data:`MAX_ELEMENTS` steps and patches together (each one
adds a contact pair per track element, checked at every time step); a height field has at most
:data:`MAX_HFIELD_CELLS` samples, checked from the file's header before its data is read (a
10 000 x 10 000 image took 6 GB and 27 s to turn into a model that then diverged).

Derivation and measurements: docs/theory/simulator.md, "Terrain contacts".
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.jsonfile import read_json
from mjtrack.models.coulomb import incline_rotation

PATCH_THICKNESS = 0.001  # [m] patches are this thick, lying on the ground
STEP_DEPTH = 100.0  # [m] extent of a step box beyond its edge
GROUND_SIZE = 50.0  # [m] half size of the ground plane (visual extent)
EDGE_TIMESTEP = 0.0025  # [s] largest time step on terrain with edges (steps, height fields): at 5 ms,
# sharp turns and reversals against a step edge at 1-2 m/s launched or diverged the robot in 2 of 40
# seeded cases (tests/test_terrain.py slow grid); at 2.5 ms none did
FLOOR_FRICTION = 1e-3  # friction of the terrain geoms themselves: unused, the contact pairs carry it
MAX_JSON_BYTES = 1 << 20  # [bytes] a terrain file (MAX_ELEMENTS patches take ~100 kB)
MAX_JSON_DEPTH = 3  # {"patches": [{"x": ...}]}
MAX_ELEMENTS = 256  # steps + patches (each is one contact pair per track element)
MAX_HFIELD_CELLS = 1_000_000  # height-field samples (1000 x 1000)
HFIELD_BYTES_PER_CELL = 60  # [bytes] measured: a 10 000 x 10 000 field took ~6 GB to build


@dataclass(frozen=True)
class Step:
    height: float  # [m]
    x: float  # [m] ground x of the edge


@dataclass(frozen=True)
class HField:
    file: str
    size_x: float  # [m] full size along x
    size_y: float  # [m] full size along y
    height: float  # [m] height of the value 1
    heights: np.ndarray = field(repr=False, compare=False, default=None)  # (nrow, ncol) in [0, 1]

    def height_at(self, x: float, y: float) -> float:
        """Height [m] of the field at ground (x, y) (nearest sample; 0 outside)."""
        nrow, ncol = self.heights.shape
        j = int(round((x / self.size_x + 0.5) * (ncol - 1)))
        i = int(round((y / self.size_y + 0.5) * (nrow - 1)))
        if 0 <= i < nrow and 0 <= j < ncol:
            return float(self.heights[i, j] * self.height)
        return 0.0


@dataclass(frozen=True)
class Patch:
    x: float
    y: float
    size_x: float
    size_y: float
    mu: float


@dataclass(frozen=True)
class Terrain:
    """Parsed terrain (see the module docstring); ``Terrain()`` is flat ground."""

    angle: float = 0.0  # [rad] incline
    direction: float = 0.0  # [rad] uphill direction in the world frame
    steps: tuple[Step, ...] = ()
    hfield: HField | None = None
    patches: tuple[Patch, ...] = ()
    spec: str = "flat"

    @property
    def is_flat(self) -> bool:
        return self.angle == 0 and not self.steps and self.hfield is None and not self.patches

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (recorded in the log's JSON under ``terrain``)."""
        d: dict[str, Any] = {"spec": self.spec}
        if self.angle:
            d["incline"] = {"angle": self.angle, "direction": self.direction}
        if self.steps:
            d["steps"] = [asdict(s) for s in self.steps]
        if self.hfield is not None:
            d["hfield"] = {k: getattr(self.hfield, k) for k in ("file", "size_x", "size_y", "height")}
        if self.patches:
            d["patches"] = [asdict(p) for p in self.patches]
        return d

    @property
    def quat(self) -> np.ndarray:
        """Rotation (w, x, y, z) from the world to the ground frame (the incline)."""
        return _incline_quat(self.angle, self.direction)

    def height_under(self, half_length: float, half_width: float) -> float:
        """Highest terrain point [m, ground frame] under a footprint centred at the origin."""
        h = 0.0
        for s in self.steps:
            if s.x <= half_length:
                h = max(h, s.height)
        for p in self.patches:
            if abs(p.x) - p.size_x / 2 <= half_length and abs(p.y) - p.size_y / 2 <= half_width:
                h = max(h, PATCH_THICKNESS)
        if self.hfield is not None:
            for x in np.linspace(-half_length, half_length, 9):
                for y in np.linspace(-half_width, half_width, 5):
                    h = max(h, self.hfield.height_at(x, y))
        return h


def timestep_for(timestep: float, terrain: Terrain | None) -> float:
    """The time step to simulate ``terrain`` with: at most :data:`EDGE_TIMESTEP` where it has edges."""
    if terrain is not None and (terrain.steps or terrain.hfield is not None):
        return min(timestep, EDGE_TIMESTEP)
    return timestep


def with_terrain(robot, terrain: Terrain):
    """The robot description to write beside a log: ``robot`` with key ``terrain`` (the terrain's
    :meth:`Terrain.to_dict`) when the terrain is not flat, without it when it is."""
    import dataclasses

    extra = {k: v for k, v in robot.extra.items() if k != "terrain"}
    if not terrain.is_flat:
        extra["terrain"] = terrain.to_dict()
    return dataclasses.replace(robot, extra=extra)


def _incline_quat(angle: float, direction: float) -> np.ndarray:
    """The ground frame's orientation (w, x, y, z): :func:`mjtrack.models.coulomb.incline_rotation`."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, incline_rotation(angle, direction).ravel())
    return q


def _num(text: str, what: str, spec: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"terrain={spec!r}: {what} must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise InputError(f"terrain={spec!r}: {what} must be finite, got {text!r}")
    return v


def _check_incline(angle: float, spec: str) -> None:
    if not abs(angle) < 1.2:
        raise InputError(f"terrain={spec!r}: incline angle must be in (-1.2, 1.2) rad, got {angle:g}")


def _check_step(s: Step, spec: str) -> None:
    if not 0 < s.height <= 5:
        raise InputError(f"terrain={spec!r}: step height must be in (0, 5] m, got {s.height:g}")
    _plausible(s.x, MAX_COORD, "step X [m]", spec)


MAX_COORD = 1e6  # [m] coordinates and sizes beyond this are not terrain (the drive-log bound)


def _plausible(value: float, limit: float, what: str, spec: str) -> None:
    if not abs(value) <= limit:
        raise InputError(f"terrain={spec!r}: {what} = {value:g} is beyond physical plausibility (|value| <= {limit:g})")


def _check_cells(shape: tuple[int, ...], path: Path, spec: str) -> None:
    """Refuse a height field with more than :data:`MAX_HFIELD_CELLS` samples, with the estimate."""
    cells = math.prod(int(n) for n in shape[:2]) if len(shape) >= 2 else math.prod(int(n) for n in shape)
    if cells > MAX_HFIELD_CELLS:
        dims = " x ".join(str(int(n)) for n in shape[:2])
        raise InputError(f"terrain={spec!r}: {path}: height field of {dims} = {cells:.3g} samples would take about "
                         f"{cells * HFIELD_BYTES_PER_CELL / 1e9:.2g} GB to build; at most {MAX_HFIELD_CELLS:.3g} "
                         f"samples (resample the file)")


def _npy_shape(path: Path) -> tuple[int, ...]:
    """The array shape in a .npy file's header (the data is not read)."""
    with open(path, "rb") as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, _ = np.lib.format.read_array_header_1_0(fh)
        else:
            shape, _, _ = np.lib.format.read_array_header_2_0(fh)
    return tuple(shape)


def load_heights(path: Path, spec: str) -> np.ndarray:
    """Heights (nrow, ncol) scaled to [0, 1] from a .npy or .png file."""
    if not path.exists():
        raise InputError(f"terrain={spec!r}: height field file {path} not found")
    if path.suffix.lower() == ".npy":
        try:
            _check_cells(_npy_shape(path), path, spec)
            a = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise InputError(f"terrain={spec!r}: {path}: not a numpy array file ({exc})") from None
    elif path.suffix.lower() == ".png":
        try:
            import imageio.v3 as iio

            with warnings.catch_warnings():  # Pillow warns of "decompression bombs": refused below anyway
                warnings.simplefilter("ignore")
                shape = iio.improps(path).shape
            _check_cells(shape, path, spec)
            a = iio.imread(path)
        except InputError:
            raise
        except Exception as exc:  # imageio raises many kinds for a bad image
            raise InputError(f"terrain={spec!r}: {path}: cannot read the image ({exc})") from None
        if a.ndim == 3:
            a = a[..., :3].mean(axis=2)
    else:
        raise InputError(f"terrain={spec!r}: height field must be a .npy or .png file, got {path.name}")
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or min(a.shape) < 2:
        raise InputError(f"terrain={spec!r}: {path}: heights must be a 2-D array of at least 2 x 2, "
                         f"got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"terrain={spec!r}: {path}: heights contain NaN or inf")
    lo, hi = a.min(), a.max()
    return (a - lo) / (hi - lo) if hi > lo else np.zeros_like(a)


def _hfield(file: str, sx: float, sy: float, h: float, spec: str, base: Path) -> HField:
    path = Path(file) if Path(file).is_absolute() else base / file
    if not (sx > 0 and sy > 0 and h >= 0):
        raise InputError(f"terrain={spec!r}: height field sizes must be > 0 and HEIGHT >= 0")
    _plausible(sx, MAX_COORD, "height field SIZE_X [m]", spec)
    _plausible(sy, MAX_COORD, "height field SIZE_Y [m]", spec)
    _plausible(h, 5.0, "height field HEIGHT [m]", spec)  # the bound of a step
    return HField(file=str(path), size_x=sx, size_y=sy, height=h, heights=load_heights(path, spec))


def _check_elements(n: int, spec: str) -> None:
    if n > MAX_ELEMENTS:
        raise InputError(f"terrain={spec!r}: {n} steps and patches; at most {MAX_ELEMENTS} (each adds a contact "
                         "with every track element at every time step)")


def _patches(items: Any, spec: str) -> tuple[Patch, ...]:
    if not isinstance(items, list):
        raise InputError(f"terrain={spec!r}: 'patches' must be a list of rectangles")
    _check_elements(len(items), spec)
    out = []
    for i, p in enumerate(items):
        if not isinstance(p, dict):
            raise InputError(f"terrain={spec!r}: patch {i} must be an object")
        vals = {}
        for k in ("x", "y", "size_x", "size_y", "mu"):
            v = p.get(k)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise InputError(f"terrain={spec!r}: patch {i}: '{k}' must be a number, got {v!r}")
            vals[k] = float(v)
        if vals["size_x"] <= 0 or vals["size_y"] <= 0 or vals["mu"] <= 0:
            raise InputError(f"terrain={spec!r}: patch {i}: sizes and 'mu' must be positive")
        for k in ("x", "y", "size_x", "size_y"):
            _plausible(vals[k], MAX_COORD, f"patch {i} '{k}' [m]", spec)
        _plausible(vals["mu"], 10.0, f"patch {i} 'mu'", spec)  # the robot description's bound
        out.append(Patch(**vals))
    return tuple(out)


def _read_json(path: Path, spec: str) -> Any:
    return read_json(path, what="terrain file", max_bytes=MAX_JSON_BYTES, max_depth=MAX_JSON_DEPTH,
                     where=f"terrain={spec!r}: {path}")


def _from_json(data: Any, spec: str, base: Path) -> Terrain:
    if not isinstance(data, dict):
        raise InputError(f"terrain={spec!r}: expected a JSON object")
    unknown = set(data) - {"incline", "steps", "hfield", "patches"}
    if unknown:
        raise InputError(f"terrain={spec!r}: unknown key(s) {sorted(unknown)}")

    def number(d: dict, k: str, default=None) -> float:
        v = d.get(k, default)
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise InputError(f"terrain={spec!r}: '{k}' must be a number, got {v!r}")
        return float(v)

    angle = direction = 0.0
    if "incline" in data:
        inc = data["incline"]
        if not isinstance(inc, dict):
            raise InputError(f"terrain={spec!r}: 'incline' must be an object")
        angle, direction = number(inc, "angle"), number(inc, "direction", 0.0)
        _check_incline(angle, spec)
    steps = []
    if not isinstance(data.get("steps", []), list):
        raise InputError(f"terrain={spec!r}: 'steps' must be a list of objects")
    patches_given = data.get("patches", [])
    _check_elements(len(data.get("steps", [])) + (len(patches_given) if isinstance(patches_given, list) else 0), spec)
    for s in data.get("steps", []):
        if not isinstance(s, dict):
            raise InputError(f"terrain={spec!r}: each step must be an object")
        steps.append(Step(height=number(s, "height"), x=number(s, "x")))
        _check_step(steps[-1], spec)
    hf = None
    if "hfield" in data:
        h = data["hfield"]
        if not isinstance(h, dict) or not isinstance(h.get("file"), str):
            raise InputError(f"terrain={spec!r}: 'hfield' must be an object with a 'file'")
        hf = _hfield(h["file"], number(h, "size_x"), number(h, "size_y"), number(h, "height"), spec, base)
    patches = _patches(data.get("patches", []), spec)
    return Terrain(angle=angle, direction=direction, steps=tuple(steps), hfield=hf, patches=patches, spec=spec)


def parse_terrain(spec: str | None) -> Terrain:
    """A ``--terrain`` spec as a :class:`Terrain`; bad specs raise a one-line InputError."""
    if spec is None or spec == "flat":
        return Terrain()
    kind, _, rest = spec.partition(":")
    parts = rest.split(":") if rest else []
    if kind == "incline":
        if len(parts) not in (1, 2):
            raise InputError(f"terrain={spec!r}: expected incline:ANGLE[:DIR]")
        angle = _num(parts[0], "ANGLE", spec)
        direction = _num(parts[1], "DIR", spec) if len(parts) == 2 else 0.0
        _check_incline(angle, spec)
        return Terrain(angle=angle, direction=direction, spec=spec)
    if kind == "step":
        if len(parts) != 2:
            raise InputError(f"terrain={spec!r}: expected step:HEIGHT:X")
        s = Step(height=_num(parts[0], "HEIGHT", spec), x=_num(parts[1], "X", spec))
        _check_step(s, spec)
        return Terrain(steps=(s,), spec=spec)
    if kind == "hfield":
        if len(parts) != 4:
            raise InputError(f"terrain={spec!r}: expected hfield:FILE:SIZE_X:SIZE_Y:HEIGHT")
        return Terrain(hfield=_hfield(parts[0], _num(parts[1], "SIZE_X", spec), _num(parts[2], "SIZE_Y", spec),
                                      _num(parts[3], "HEIGHT", spec), spec, Path(".")), spec=spec)
    if kind == "patches":
        if len(parts) != 1:
            raise InputError(f"terrain={spec!r}: expected patches:FILE.json")
        path = Path(parts[0])
        data = _read_json(path, spec)
        items = data.get("patches") if isinstance(data, dict) else data
        return Terrain(patches=_patches(items, spec), spec=spec)
    if spec.endswith(".json") and not parts:
        path = Path(spec)
        return _from_json(_read_json(path, spec), spec, path.parent)
    raise InputError(f"terrain={spec!r}: unknown terrain; use flat, incline:ANGLE[:DIR], step:HEIGHT:X, "
                     "hfield:FILE:SX:SY:H, patches:FILE.json or FILE.json")


def add_terrain(spec: mujoco.MjSpec, terrain: Terrain, contacts: list[tuple[str, float]], *, nominal_mu: float,
                pair_options: dict[str, Any]) -> None:
    """Add the terrain geoms to ``spec`` and one contact pair per (contact geom, terrain geom).

    Args:
        contacts: (geom name, track μ) of every track contact element (μ 0: a frictionless,
            condim-1 pair); the pair with the ground
            plane is ``contact_<suffix>``, with another terrain geom ``<terrain geom>_<suffix>``,
            suffix the element's name after its first ``_`` (``roller_left_3`` -> ``left_3``).
        nominal_mu: the robot's nominal μ (patch friction rule, module docstring).
        pair_options: condim, solref, solimp, solreffriction, margin of every pair.
    """
    # flat: the geoms in the world body (the model of the flat ground is unchanged)
    ground = spec.worldbody if terrain.angle == 0 else spec.worldbody.add_body(name="ground", quat=terrain.quat)
    geoms: list[tuple[str, float | None]] = []  # (name, patch μ or None for ground)
    ground.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[GROUND_SIZE, GROUND_SIZE, 0.1],
                    friction=[FLOOR_FRICTION, 0, 0], rgba=[0.8, 0.8, 0.75, 1])
    geoms.append(("floor", None))
    for i, s in enumerate(terrain.steps):
        ground.add_geom(name=f"step_{i}", type=mujoco.mjtGeom.mjGEOM_BOX,
                        size=[STEP_DEPTH / 2, GROUND_SIZE, s.height / 2],
                        pos=[s.x + STEP_DEPTH / 2, 0, s.height / 2], friction=[FLOOR_FRICTION, 0, 0], rgba=[0.6, 0.55, 0.5, 1])
        geoms.append((f"step_{i}", None))
    if terrain.hfield is not None:
        hf = terrain.hfield
        nrow, ncol = hf.heights.shape
        spec.add_hfield(name="terrain_hfield", size=[hf.size_x / 2, hf.size_y / 2, max(hf.height, 1e-6), 0.05],
                        nrow=nrow, ncol=ncol, userdata=hf.heights.astype(np.float32).ravel().tolist())
        ground.add_geom(name="hfield", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain_hfield",
                        friction=[FLOOR_FRICTION, 0, 0], rgba=[0.55, 0.6, 0.45, 1])
        geoms.append(("hfield", None))
    for i, p in enumerate(terrain.patches):
        ground.add_geom(name=f"patch_{i}", type=mujoco.mjtGeom.mjGEOM_BOX,
                        size=[p.size_x / 2, p.size_y / 2, PATCH_THICKNESS / 2],
                        pos=[p.x, p.y, PATCH_THICKNESS / 2], friction=[FLOOR_FRICTION, 0, 0], rgba=[0.7, 0.85, 1.0, 1])
        geoms.append((f"patch_{i}", p.mu))
    for gname, patch_mu in geoms:
        for cname, mu_track in contacts:
            mu = mu_track if patch_mu is None else patch_mu * mu_track / nominal_mu
            suffix = cname.partition("_")[2]
            pname = f"contact_{suffix}" if gname == "floor" else f"{gname}_{suffix}"
            options = dict(pair_options, condim=1) if mu == 0 else pair_options  # mu 0: frictionless
            spec.add_pair(name=pname, geomname1=gname, geomname2=cname,
                          friction=[mu, mu, 0.0, 0.0, 0.0], **options)
