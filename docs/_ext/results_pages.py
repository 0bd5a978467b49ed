"""The results pages, generated from the stored result files of the benchmark scripts.

Run by the documentation build (a Sphinx extension: the pages are written when the build
starts) or alone::

    python docs/_ext/results_pages.py [OUT_DIR]       # default docs/results

Every number on a results page is read here from a result file under
:data:`RESULTS`; nothing is typed. Beside the pages the generator writes
``_provenance.json``: for every number, the file and the JSON pointer it came from (and the
reduction, for a mean or maximum over a list), so that ``tests/test_docs_results.py`` can check
each printed number against its file independently of this module.
"""

from __future__ import annotations

import json
import math
import shutil
import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]  # docs/_ext/results_pages.py
RESULTS = ROOT / "benchmarks" / "results"
"""The stored result files the pages are generated from (the benchmark scripts' folder)."""
DEFAULT_OUT = HERE.parent / "results"
SIGNIFICANT = 3  # significant digits of a printed float


# -- reading values with their provenance ------------------------------------------------------
def pointer_get(data: Any, pointer: str) -> Any:
    """The value at a JSON pointer (RFC 6901: ``/a/0/b``)."""
    value = data
    for token in pointer.split("/")[1:]:
        token = token.replace("~1", "/").replace("~0", "~")
        value = value[int(token)] if isinstance(value, list) else value[token]
    return value


def pointer_token(key: str) -> str:
    """``key`` as one token of a JSON pointer (RFC 6901: ``~`` and ``/`` escaped; :func:`pointer_get`)."""
    return key.replace("~", "~0").replace("/", "~1")


REDUCTIONS: dict[str, Callable[[list[float]], float]] = {
    "mean": statistics.fmean, "max": max, "min": min, "median": statistics.median,
    "count": lambda items: sum(1 for v in items if v is True),  # how many items' field is true
    "length": len,  # how many items
}


@dataclass
class Source:
    """One result file: its path relative to the repository and its parsed content."""

    path: Path

    def __post_init__(self) -> None:
        self.data = json.loads(self.path.read_text())

    @property
    def rel(self) -> str:
        return self.path.relative_to(ROOT).as_posix()

    @property
    def command(self) -> str | None:
        return self.data.get("command") if isinstance(self.data, dict) else None


@dataclass
class Cell:
    """A table cell: text, or a number with where it came from."""

    text: str
    provenance: dict | None = None


def number(src: Source, pointer: str, *, reduce: str | None = None, field_name: str | None = None,
           scale: float = 1.0) -> Cell:
    """A cell with the value at ``pointer`` (a list reduced by ``reduce`` over its items' field
    ``field_name``), times ``scale``, printed to :data:`SIGNIFICANT` digits (integers exactly)."""
    value = pointer_get(src.data, pointer)
    if reduce is not None:
        items = [v[field_name] if field_name else v for v in value]
        value = REDUCTIONS[reduce](items)
    prov = {"file": src.rel, "pointer": pointer, "reduce": reduce, "field": field_name, "scale": scale}
    if value is None:
        return Cell("n/a", {**prov, "kind": "null"})
    if isinstance(value, bool):
        return Cell("yes" if value else "no", {**prov, "kind": "bool"})
    if scale != 1.0:
        value = value * scale
    if isinstance(value, int):
        return Cell(str(value), {**prov, "kind": "number"})
    if not math.isfinite(value):
        return Cell(str(value), {**prov, "kind": "number"})
    return Cell(f"{value:.{SIGNIFICANT}g}", {**prov, "kind": "number"})


@dataclass
class Table:
    caption: str
    header: list[str]
    rows: list[list[Cell | str]] = field(default_factory=list)

    def add(self, *cells: Cell | str) -> None:
        assert len(cells) == len(self.header), (self.caption, cells)
        self.rows.append([c if isinstance(c, Cell) else Cell(c) for c in cells])


@dataclass
class Page:
    name: str
    title: str
    intro: str
    sources: list[Source]
    tables: list[Table]
    figures: list[tuple[Path, str]] = field(default_factory=list)  # (result figure, caption)
    written: list[Path] = field(default_factory=list)  # files the runs wrote beside the result files


def _turn_class_names() -> dict[str, str]:
    """The words for calibrate's turn classes, keyed by the suffix its findings carry
    ("(|turn ratio| 0.15 to 0.5)" -> "turning")."""
    from mjtrack.calibrate.measures import TURN_CLASSES

    return dict(zip((f"(|turn ratio| {lo:g} to {hi:g})" for lo, hi in TURN_CLASSES),
                    ("straight", "turning", "sharp turns")))


def add_rows(table: Table, src: Source, rows: list[tuple[str, str]]) -> None:
    """One (label, number at pointer) row per pair, for a two-column quantity table."""
    for label, pointer in rows:
        table.add(label, number(src, pointer))


def add_load(table: Table, src: Source, before: str, after: str) -> None:
    """The run's one-minute load averages before and after (pointers into ``src``) as two rows."""
    table.add("load average before (one minute)", number(src, before))
    table.add("load average after (one minute)", number(src, after))


# -- the pages ---------------------------------------------------------------------------------
def _fidelity() -> Page:
    rollers = Source(RESULTS / "fidelity" / "fidelity.json")
    surfacevel = Source(RESULTS / "fidelity" / "fidelity_surfacevel.json")
    wide = Source(RESULTS / "fidelity" / "fidelity_wide_rollers.json")
    holdout = Source(RESULTS / "fidelity" / "fidelity_wide_holdout_rollers.json")
    steady = Table("Steady turns against the rigid-track Coulomb reference, per track model and robot geometry. "
                   "Errors: the largest ICR distance, lateral over half the gauge T/2 and longitudinal over the "
                   "contact length L.",
                   ["track model", "geometry", "cases", "passed", "max |Δy| / (T/2)", "max |Δx_c| / L",
                    "min contact fraction"])
    for label, src in (("rollers", rollers), ("surfacevel", surfacevel)):
        for geom in ("default", "long"):
            p = f"/summary/{geom}"
            steady.add(label, geom, number(src, p + "/cases"), number(src, p + "/passed"),
                       number(src, p + "/max_err_y_over_half_gauge"), number(src, p + "/max_err_x_over_length"),
                       number(src, p + "/min_contact_fraction"))
    conv = Table("Convergence of the roller chain: how far the steady ICRs move when the time step is halved or the "
                 "rollers are doubled.", ["check", "cases", "max |Δy| / (T/2)", "max |Δx_c| / L"])
    for key, label in (("half_dt", "time step halved"), ("double_rollers", "rollers doubled")):
        p = f"/convergence/{key}"
        conv.add(label, number(rollers, p + "/cases"), number(rollers, p + "/max_dy_over_half_gauge"),
                 number(rollers, p + "/max_dx_over_length"))
    straight = Table("Straight driving of the roller chain: measured speed against the command, and sideways drift.",
                     ["command [m/s]", "relative speed error", "drift [mm/m]"])
    for i in range(len(rollers.data["straight"])):
        p = f"/straight/{i}"
        straight.add(number(rollers, p + "/v_cmd"), number(rollers, p + "/rel_speed_err"),
                     number(rollers, p + "/drift_mm_per_m"))
    grids = Table("The wider grid (robots of other mass and proportions, gentle to sharp turns, slow to fast) and its "
                  "hold-out grid, roller chain. Pass: within the file's tolerances in every check.",
                  ["grid", "cases", "passed", "worst |Δy| / (T/2)", "median |Δy| / (T/2)", "worst |Δx_c| / L",
                   "median |Δx_c| / L", "worst time-step halving |Δy| / (T/2)", "min contact fraction"])
    for label, src in (("wide", wide), ("hold-out", holdout)):
        p = "/rollers/summary"
        grids.add(label, number(src, p + "/cases"), number(src, p + "/passed"), number(src, p + "/worst_err_y/value"),
                  number(src, p + "/median_err_y"), number(src, p + "/worst_err_x/value"), number(src, p + "/median_err_x"),
                  number(src, p + "/worst_dt_dy/value"), number(src, p + "/min_contact"))
    tol = Table("Tolerances of the wider grids, as stored with the results.", ["tolerance", "wide", "hold-out"])
    for key in wide.data["tolerances"]:
        tol.add(key, number(wide, f"/tolerances/{key}"), number(holdout, f"/tolerances/{key}"))
    return Page(
        "fidelity", "Fidelity against Coulomb theory",
        "The MuJoCo robot's steady turns compared with the rigid-track Coulomb reference of the same description "
        "(see the concepts page on the Coulomb reference): each case holds constant track speeds, averages the "
        "twist, and compares the measured ICRs with the reference's.",
        [rollers, surfacevel, wide, holdout], [steady, conv, straight, grids, tol],
        [(RESULTS / "fidelity" / "fidelity.png", "Roller chain against the Coulomb reference, per case.")])


def _diagnosis() -> Page:
    runs = [("seed 0", Source(RESULTS / "diagnose_benchmark.json")),
            ("seed 1000", Source(RESULTS / "diagnose_benchmark_seed1000.json"))]
    keys = [("logs", "logs"), ("with_effect", "logs with an effect above the detectability floor"),
            ("named_right", "of these, cause named right"), ("pairs", "logs with two effects"),
            ("pairs_right", "of these, both named"), ("clean", "clean logs"), ("clean_none", "of these, cause none"),
            ("extra_effects", "extra effects named"), ("below_floor", "logs below the detectability floor"),
            ("below_floor_fooled", "of these, a wrong cause named"), ("params", "estimated parameters"),
            ("covered", "of these, truth inside the interval"), ("median_abs_bias", "median relative bias"),
            ("worst_abs_bias", "worst relative bias"), ("median_diagnose_s", "median diagnosis time [s]")]
    table = Table("Summary of the diagnosis benchmark for two seeds of the log generator.",
                  ["quantity", *(label for label, _ in runs)])
    for key, label in keys:
        table.add(label, *(number(src, f"/summary/{key}") for _, src in runs))
    return Page(
        "diagnosis-benchmark", "Diagnosis benchmark",
        "Logs from the independent physics generator of the tests (`mjtrack.testing.diagnose_physics`: its own "
        "rigid-body simulation, sharing no code with the diagnosis), each with hidden effects of known size, "
        "diagnosed with the surrogate baseline. Written by `python benchmarks/diagnose_benchmark.py` "
        "(`--seed 1000` for the second column).",
        [src for _, src in runs], [table])


def _implementations() -> Page:
    src = Source(RESULTS / "diagnose_implementations.json")
    verdicts = ("right", "tie", "wrong", "spurious", "missed")
    counts = Table("Verdicts per baseline and generator: right (the true families named, nothing else), tie (named, "
                   "reported tied with another effect, both estimates given), wrong (another family named instead, or "
                   "a lag named a delay without a tie), spurious (the truth and another family), missed (nothing).",
                   ["baseline", "generator", "logs", *verdicts])
    for b, per in src.data["summary"].items():
        for g in ("A", "B", "all"):
            if per.get(g, {}).get("logs"):
                counts.add(b, g, number(src, f"/summary/{b}/{g}/logs"),
                           *(number(src, f"/summary/{b}/{g}/{v}") for v in verdicts))
    logs = Table("Every log: what was named (a tie as effect ~ effect) and the first finding's first estimate with its "
                 "interval (the diagnosis's own level).",
                 ["case", "generator", "baseline", "verdict", "named", "estimate", "low", "high", "time [s]"])
    for i, r in enumerate(src.data["rows"]):
        named = ", ".join(f["effect"] + "".join(f" ~ {t}" for t in f["tied_with"]) for f in r["findings"]) or "none"
        q = f"/rows/{i}/findings/0"
        est = [number(src, q + "/estimate/0"), number(src, q + "/interval/0/0"), number(src, q + "/interval/0/1")] \
            if r["findings"] else ["", "", ""]
        logs.add(r["case"], r["generator"], r["baseline"], r["verdict"], named, *est, number(src, f"/rows/{i}/seconds"))
    return Page(
        "diagnosis-implementations", "Diagnosis across implementations of an effect",
        "Each effect family in physically different implementations (`mjtrack.testing.implementations`: a lag on "
        "the track speed and on the drive force, a dead time, rate and force limits, Coulomb and anisotropic ground, "
        "a centre-of-mass offset, a lag beside one, a lag on a light robot, a lag with a dead time, a clean log), each from two generators "
        "that share no code with the diagnosis (A: `mjtrack.testing.diagnose_physics`; B: "
        "`mjtrack.testing.bristle_physics`, bristle friction and driven belts with inertia). Pose-only logs with "
        "pose noise, diagnosed at default options with the named baseline (auto: the MuJoCo robot, screened by the "
        "surrogate).",
        [src], [counts, logs])


def _filters() -> Page:
    src = Source(RESULTS / "filter_consistency.json")
    table = Table("Normalised innovation and estimation error squared per degree of freedom (NIS, NEES) of each "
                  "filter, the mean over every sample of the three noise seeds, beside the two-sided interval a "
                  "consistent filter's mean of that many samples lies in with probability `p = 0.95`: "
                  "`chi2.ppf((1 -+ p)/2, N*d) / (N*d)` for N samples of d degrees of freedom "
                  "(`mjtrack.estimation.consistency.pooled`, the rule the benchmark passes or fails by). The NIS "
                  "samples of a consistent filter are independent; the NEES samples are correlated from step to "
                  "step, so their interval is narrower than the mean's real spread: a NEES mean outside it is a "
                  "flag, not a proof. Pass: both means inside.",
                  ["case", "filter", "NIS / dof", "NIS low", "NIS high", "NEES / dof", "NEES low", "NEES high",
                   "NIS inside", "NEES inside", "pass"])
    for case, c in src.data["cases"].items():
        for name in c["filters"]:
            p = f"/cases/{case}/pooled/{name}"
            table.add(case, name, number(src, p + "/nis_per_dof"), number(src, p + "/nis_band/0"),
                      number(src, p + "/nis_band/1"), number(src, p + "/nees_per_dof"), number(src, p + "/nees_band/0"),
                      number(src, p + "/nees_band/1"), number(src, p + "/nis_inside"), number(src, p + "/nees_inside"),
                      number(src, f"/cases/{case}/pass/{name}"))
    return Page(
        "filter-consistency", "Filter consistency",
        "The three parameter filters (slip EKF, ICR EKF, virtual-robot filter), each as a plain random walk and with "
        "adaptive process noise (`_imm`), run on MuJoCo logs with seeded measurement noise. Written by "
        "`python benchmarks/filter_consistency.py`.",
        [src], [table])


def _speed() -> Page:
    src = Source(RESULTS / "bench_sim.json")
    rt = Table("Real-time factor of the default robot (random steps), previous and current default settings timed "
               "in one run.", ["settings", "real-time factor", "per CPU second", "steps per second", "time step [s]"])
    for key, label in (("old", "previous defaults"), ("new", "current defaults")):
        p = f"/realtime/{key}"
        rt.add(label, number(src, p + "/realtime_factor"), number(src, p + "/realtime_factor_per_cpu_second"),
               number(src, p + "/steps_per_second"), number(src, p + "/timestep"))
    prof = Table("Where a step goes (MuJoCo's timers), current defaults [ms per step].", ["stage", "ms"])
    for key in ("step_ms", "position_ms", "velocity_ms", "actuation_ms", "constraint_ms", "advance_ms"):
        prof.add(key.removesuffix("_ms"), number(src, f"/profile/new/{key}"))
    rollers = Table("Cost against the number of rollers per track, current defaults.",
                    ["rollers", "steps per second", "real-time factor", "cost relative to ten rollers"])
    for i in range(len(src.data["rollers"]["new"])):
        p = f"/rollers/new/{i}"
        rollers.add(number(src, p + "/n_rollers"), number(src, p + "/steps_per_second"),
                    number(src, p + "/realtime_factor"), number(src, p + "/cost_vs_10"))
    other = Table("A batch of rollouts on one and two threads, and the surfacevel track model.", ["quantity", "value"])
    other.add("batch size", number(src, "/batch/nbatch"))
    other.add("batch speed-up, two threads over one", number(src, "/batch/speedup"))
    other.add("surfacevel real-time factor", number(src, "/surfacevel/realtime_factor"))
    other.add("surfacevel time step [s]", number(src, "/surfacevel/timestep"))
    add_load(other, src, "/loadavg_before/0", "/loadavg_after/0")
    tables = [rt, prof, rollers, other]
    sources = [src]
    sim60 = RESULTS / "bench_calibrate.json"
    if sim60.exists():
        cal = Source(sim60)
        sources.append(cal)
        tables.append(_calibration_ab(cal, "Calibration of a one-minute simulated log with one hidden change (the "
                                           "centre of mass moved ahead, cg_x) and a held-out log of the same length, "
                                           "calibrate's defaults: the code before the speed work (old) and now (new), "
                                           "alternating in one run, medians; stage times of the first run of each."))
    diag60 = RESULTS / "bench_diagnose_mujoco60.json"
    if diag60.exists():
        diag = Source(diag60)
        sources.append(diag)
        tables.append(_diagnose_ab(diag))
        if "profile" in diag.data:
            tables.append(_diagnose_profile(diag))
        if "noslip_cap" in diag.data:
            tables.append(_diagnose_noslip(diag))
    marmotte = Source(RESULTS / "bench_calibrate_marmotte.json")
    sources.append(marmotte)
    tables.append(_calibration_ab(marmotte, "Calibration of the whole shared Marmotte log (the fit uses --fit-windows "
                                            "of its windows), 6 rollers per track, the code before and after the causes were "
                                            "scored on the fit's windows instead of every training window (stage "
                                            "after); old and new alternating in one run.")
                  if "runs" in marmotte.data else _calibration_whole(marmotte))
    for robot, title in (("husky", "Husky"), ("warthog", "Warthog")):
        path = RESULTS / f"bench_calibrate_{robot}.json"
        if path.exists():
            whole = Source(path)
            sources.append(whole)
            tables.append(_calibration_ab(whole, f"Calibration of the whole shared {title} log from the description "
                                                 "shipped with it, calibrate's defaults, as a new user runs it: the "
                                                 "code whose default drive input was `commanded` (old) and the code "
                                                 "now, whose default `auto` fits the drivetrain to the measured track "
                                                 "speeds first when they show the robot's speed controller capping "
                                                 "the commands (new), alternating in one run; the summaries are in "
                                                 "the result file."))
    gpu_path = RESULTS / "gpu_rollout.json"
    if gpu_path.exists():
        gpu = Source(gpu_path)
        sources.append(gpu)
        tables += _gpu_tables(gpu)
    check_path = RESULTS / "gpu_rollout_cpu_device.json"
    if check_path.exists():
        check = Source(check_path)
        sources.append(check)
        tables.append(_gpu_check(check))
    demo = Source(RESULTS / "bench_demo.json")
    dem_tables = _demo_tables(demo)
    sweep = Source(RESULTS / "bench_sweep.json")
    sw = Table("`mjtrack sweep` of a small grid on a local cluster of one and of two worker processes (median of "
               "the repeats): the sweep's own time, the whole call, and whether both wrote the same sweep.csv.",
               ["quantity", "value"])
    add_rows(sw, sweep, [("cases", "/cases"), ("one worker, sweep [s]", "/one_worker/run_seconds"),
                         ("two workers, sweep [s]", "/two_workers/run_seconds"), ("speed-up of the sweep", "/speedup_run"),
                         ("speed-up of the whole call", "/speedup_total"), ("identical sweep.csv", "/identical_csv")])
    add_load(sw, sweep, "/loadavg_before/0", "/loadavg_after/0")
    return Page(
        "speed", "Speed",
        "Timings depend on the machine and its load; each table gives the load averages of its run.",
        sources + [demo, sweep], tables + dem_tables + [sw])


def _gpu_tables(gpu: Source) -> list[Table]:
    """Batched rollouts on a lent GPU against its machine's CPU (benchmarks/bench_sim.py --gpu)."""
    refused = Table("What MuJoCo Warp (`mujoco_warp.put_model`) says of each model as mjtrack builds it, and what "
                    "was changed so that it runs (the adapted model, timed below on both).",
                    ["model", "as built", "adapted"])
    seen = set()
    speed = Table("Batched rollouts of the three MuJoCo robots on a lent GPU (MuJoCo Warp, one CUDA graph per "
                  "batch of steps; the GPU and the versions are in the result file) against `mujoco.rollout` "
                  "on every CPU thread of the same machine, each world from the robot settled at rest under its own "
                  "constant command: steps per second over all worlds; the speed-ups of the GPU over the CPU with "
                  "the model as built and with the same adapted model; agreement: the largest distance between the "
                  "chassis positions the GPU and the CPU reach after the same steps of the adapted model; shift: "
                  "what the adaptation alone moves the chassis on the CPU over the run; path: how far the chassis "
                  "went (adapted, CPU). This run also took out the noslip pass (`--drop-noslip`), which carries "
                  "the friction of these models: its shift is the friction lost, and its GPU times leave out "
                  "the pass's cost; the next table checks the adaptation that keeps it.",
                  ["model", "worlds", "CPU threads", "CPU as built", "CPU adapted", "GPU", "speed-up over as built",
                   "speed-up, same model", "agreement [m]", "shift [m]", "path [m]"])
    for i, r in enumerate(gpu.data["rows"]):
        q = f"/rows/{i}"
        if r["model"] not in seen:
            seen.add(r["model"])
            refused.add(r["model"], r.get("gpu_as_built", "n/a"), "; ".join(r.get("adapted", [])) or "nothing")
        if "gpu_steps_per_s" not in r:
            continue
        speed.add(r["model"], number(gpu, q + "/worlds"), number(gpu, "/machine/cpu_threads"),
                  number(gpu, q + "/cpu_steps_per_s"), number(gpu, q + "/cpu_adapted_steps_per_s"),
                  number(gpu, q + "/gpu_steps_per_s"), number(gpu, q + "/speedup"),
                  number(gpu, q + "/speedup_same_model"), number(gpu, q + "/agreement_m"),
                  number(gpu, q + "/adaptation_shift_m"), number(gpu, q + "/cpu_path_m"))
    return [refused, speed]


def _gpu_check(check: Source) -> Table:
    """MuJoCo Warp on warp's CPU device with the noslip pass kept: accepted, and the same motion?"""
    t = Table("MuJoCo Warp run on warp's CPU device (no GPU; its times mean nothing) with the noslip pass kept, "
              "the adaptation the GPU table above could not be rerun with: agreement with `mujoco.rollout` on the "
              "same adapted model, the adaptation's shift of the motion on the CPU, and the path, after the same "
              "steps (`python benchmarks/bench_sim.py --gpu --device cpu`, its options in the result file).",
              ["model", "worlds", "adapted", "agreement [m]", "shift [m]", "path [m]"])
    for i, r in enumerate(check.data["rows"]):
        if "agreement_m" not in r:
            continue
        q = f"/rows/{i}"
        t.add(r["model"], number(check, q + "/worlds"), "; ".join(r.get("adapted", [])) or "nothing",
              number(check, q + "/agreement_m"), number(check, q + "/adaptation_shift_m"),
              number(check, q + "/cpu_path_m"))
    return t


def _demo_tables(demo: Source) -> list[Table]:
    """`mjtrack demo` (benchmarks/bench_demo.py): wall and CPU time per stage, the code before the speed
    work (old) and now (new) in one run, and the profile of each: where the seconds go."""
    labels = [k for k in ("old", "new") if k in demo.data.get("runs", {})]
    if not labels:  # a result stored before the old/new runs
        dem = Table("`mjtrack demo` end to end on its defaults: wall time, per stage.", ["quantity", "value"])
        add_rows(dem, demo, [("wall time [s]", "/wall_s"),
                             *((f"stage {stage} [s]", f"/stage_s/{stage}") for stage in demo.data["stage_s"]),
                             ("CPUs", "/cpus")])
        add_load(dem, demo, "/load_average_before/0", "/load_average_after/0")
        return [dem]
    runs = Table("`mjtrack demo` end to end on its defaults, the code before the speed work (old) and now (new) "
                 "alternating in one run: median wall and CPU time (the CPU time of every process, the video worker "
                 "and the encoder included), the stages of the first run of each (the code now makes the video "
                 "beside the validation, so its stages overlap), and the load.", ["quantity"] + labels)
    for name, pointer in (("wall time, median [s]", "/medians/{k}/wall_s"),
                          ("CPU time, median [s]", "/medians/{k}/cpu_s"),
                          ("of which the demo's own process [s]", "/medians/{k}/cpu_main_s"),
                          ("of which the processes it waited for (video worker, encoder) [s]",
                           "/medians/{k}/cpu_workers_s"),
                          *((f"stage {st} [s]", f"/runs/{{k}}/0/stage_s/{st}") for st in ("rollout", "validate", "video")),
                          ("load average before (one minute)", "/runs/{k}/0/load_before/0"),
                          ("load average after (one minute)", "/runs/{k}/0/load_after/0")):
        runs.add(name, *(number(demo, pointer.format(k=k)) for k in labels))
    tables = [runs]
    prof = [k for k in labels if k in demo.data.get("profile", {})]
    if prof:
        where = Table("Where the demo's seconds go: one run of each code under cProfile, everything in one process "
                      "(the video after the validation), cumulative wall seconds of each part on the loaded machine; "
                      "cProfile slows the Python parts (the filters, the decorations) more than the rest.",
                      ["part"] + prof)
        for part in demo.data["profile"][prof[-1]]["parts_s"]:
            where.add(part, *(number(demo, f"/profile/{k}/parts_s/{part}") for k in prof))
        for name, key in (("frames", "frames"), ("rendering per frame [ms]", "render_ms_per_frame"),
                          ("decorations per frame [ms]", "decorations_ms_per_frame"),
                          ("encoding per frame [ms]", "encode_ms_per_frame"), ("profiled wall time [s]", "wall_s")):
            where.add(name, *(number(demo, f"/profile/{k}/{key}") for k in prof))
        where.add("load average before (one minute)", *(number(demo, f"/profile/{k}/load_before/0") for k in prof))
        tables.append(where)
    return tables


#: calibrate's stages (Calibration.timings), in their order; an older run may lack some
CALIBRATE_STAGES = ("prepare", "before", "fit", "guard", "guard_refit", "turns", "after", "explain", "total")


def _calibration_ab(cal: Source, caption: str) -> Table:
    """Old and new calibrations of one case (benchmarks/bench_calibrate.py): times, windows
    simulated, stage times, the answer, the load."""
    labels = [k for k in ("old", "new") if k in cal.data["runs"]]
    table = Table(caption, ["quantity"] + labels)

    def row(name: str, pointer) -> None:
        cells = []
        for k in labels:
            try:
                pointer_get(cal.data, pointer(k))
            except (KeyError, IndexError):
                cells.append("–")
                continue
            cells.append(number(cal, pointer(k)))
        if any(c != "–" for c in cells):  # (a stage neither run went through is left out)
            table.add(name, *cells)

    row("wall time, median [s]", lambda k: f"/medians/{k}/wall_s")
    row("CPU time (both threads), median [s]", lambda k: f"/medians/{k}/cpu_s")
    row("windows simulated, median", lambda k: f"/medians/{k}/windows")
    for stage in CALIBRATE_STAGES:
        row(f"stage {stage} [s]", lambda k, st=stage: f"/runs/{k}/0/timings_s/{st}")
    if all("drive_input_mode" in cal.data["runs"][k][0] for k in labels):
        table.add("drive input used", *(str(cal.data["runs"][k][0]["drive_input_mode"]) for k in labels))
        row("training 2 s position error before [m]", lambda k: f"/runs/{k}/0/rms/0")
        row("training 2 s position error after [m]", lambda k: f"/runs/{k}/0/rms/1")
    changed = dict.fromkeys(n for k in labels for n in cal.data["runs"][k][0]["changed"])
    for n in changed:
        row(f"calibrated {n}", lambda k, n=n: f"/runs/{k}/0/values/{n}")
    row("load average before (one minute)", lambda k: f"/runs/{k}/0/load_before/0")
    row("load average after (one minute)", lambda k: f"/runs/{k}/0/load_after/0")
    return table


def _diagnose_ab(diag: Source) -> Table:
    """Old and new ``diagnose --baseline mujoco`` of the 60 s held-out log (benchmarks/bench_diagnose.py
    --case mujoco60): times, windows simulated, stage times, the cause named, the load."""
    labels = [k for k in ("old", "new") if k in diag.data["runs"]]
    change = diag.data.get("change")
    runs = ("old and new alternating in one run, medians; stage times and cause of the first run of each"
            + (f" (new: {change})" if change else "")
            if len(labels) > 1 else "the code now alone (the window simulator and the MuJoCo baseline are those "
            "the old calibration used), median; stage times and cause of the first run")
    table = Table("`diagnose --baseline mujoco` of the one-minute held-out log of the calibration above against "
                  f"the description without the hidden change, on its defaults: {runs}.", ["quantity"] + labels)
    first = {k: diag.data["runs"][k][0] for k in labels}
    if "target_wall_s" in diag.data:
        table.add("target wall time [s]", *(number(diag, "/target_wall_s") for _ in labels))
    table.add("wall time, median [s]", *(number(diag, f"/medians/{k}/wall_s") for k in labels))
    table.add("CPU time (both threads), median [s]", *(number(diag, f"/medians/{k}/cpu_s") for k in labels))
    table.add("windows simulated, median", *(number(diag, f"/medians/{k}/windows") for k in labels))
    for stage in first[labels[-1]]["timings_s"]:
        table.add(f"stage {stage} [s]", *(number(diag, f"/runs/{k}/0/timings_s/{stage}")
                                           if stage in first[k]["timings_s"] else "–" for k in labels))
    table.add("cause named", *(first[k]["cause"] or "none" for k in labels))
    table.add("load average before (one minute)", *(number(diag, f"/runs/{k}/0/load_before/0") for k in labels))
    table.add("load average after (one minute)", *(number(diag, f"/runs/{k}/0/load_after/0") for k in labels))
    return table


def _diagnose_noslip(diag: Source) -> Table:
    """The same diagnosis with the noslip pass capped lower (bench_diagnose.py --noslip N)."""
    t = Table("The same diagnosis, code now, with MuJoCo's noslip friction pass capped at fewer iterations than "
              "the robot is built with (its iterations below; the log was simulated with the robot as built): "
              "whether a cheaper step is where the time is.", ["quantity", "value"])
    add_rows(t, diag, [("noslip iterations at most", "/noslip_cap/noslip_iterations"),
                       ("wall time [s]", "/noslip_cap/wall_s"), ("CPU time (both threads) [s]", "/noslip_cap/cpu_s"),
                       ("windows simulated", "/noslip_cap/windows")])
    t.add("cause named", diag.data["noslip_cap"]["cause"] or "none")
    for k, f in enumerate(diag.data["noslip_cap"]["estimates"]):
        for name in f["estimate"]:
            t.add(f"estimate of {name}", number(diag, f"/noslip_cap/estimates/{k}/estimate/{name}"))
            t.add(f"interval of {name}, low", number(diag, f"/noslip_cap/estimates/{k}/interval/{name}/0"))
            t.add(f"interval of {name}, high", number(diag, f"/noslip_cap/estimates/{k}/interval/{name}/1"))
    add_load(t, diag, "/noslip_cap/load_before/0", "/noslip_cap/load_after/0")
    return t


def _diagnose_profile(diag: Source) -> Table:
    """Where the seconds of the MuJoCo diagnosis above go (bench_diagnose.py --profile-only)."""
    t = Table("Where the seconds of that diagnosis go: one more run of the code now under cProfile (its wall time "
              "and load below; cProfile slows the Python around the rollouts, not the rollouts). The parts "
              "overlap: each includes the rollouts it calls, and scoring every effect includes the grids.",
              ["part", "seconds"])
    for part in diag.data["profile"]["parts_s"]:
        t.add(part, number(diag, "/profile/parts_s/" + pointer_token(part)))
    t.add("the profiled run's wall time", number(diag, "/profile/wall_s"))
    t.add("windows simulated", number(diag, "/profile/windows"))
    add_load(t, diag, "/profile/load_before/0", "/profile/load_after/0")
    return t


def _calibration_whole(cal: Source) -> Table:
    """The whole-Marmotte calibration as an earlier benchmarks/bench_calibrate.py stored it (one run)."""
    whole = Table("Calibration of the whole shared Marmotte log at calibrate's defaults (the rollers per track of "
                  "the real-robot results), with the machine's load and the target wall time.",
                  ["quantity", "value"])
    add_rows(whole, cal, [("rollers per track", "/rollers"), ("target wall time [min]", "/target_minutes"),
                          ("windows in the log", "/windows"), ("windows the fit used", "/fit_windows"),
                          ("wall time [min]", "/minutes"),
                          *((f"stage {stage} [s]", f"/timings_s/{stage}") for stage in ("before", "fit", "after")),
                          ("parameter sets the fits evaluated", "/parameter_sets"),
                          ("windows simulated per second", "/windows_per_second"),
                          ("2 s position RMSE before [m]", "/rms_before"), ("2 s position RMSE after [m]", "/rms_after"),
                          ("windows blown up after calibration", "/diverged/1")])
    add_load(whole, cal, "/load_before/0", "/load_after/0")
    return whole


def _wheeled() -> Page:
    fid = Source(RESULTS / "wheeled_fidelity.json")
    speed = Source(RESULTS / "wheeled_speed.json")
    table = Table("Steady turns of the wheeled MuJoCo robot against the point-contact Coulomb reference, every robot "
                  "of the grid. Errors: ICR distance over half the gauge T/2.", ["quantity", "value"])
    p = "/summary"
    for key, label in (("cases", "cases"), ("passed", "passed (every check within the file's tolerances)"),
                       ("no_reference", "cases without a reference steady state"),
                       ("worst_err_y_l", "worst |Δy_l| / (T/2)"), ("median_err_y_l", "median |Δy_l| / (T/2)"),
                       ("worst_err_y_r", "worst |Δy_r| / (T/2)"), ("median_err_y_r", "median |Δy_r| / (T/2)"),
                       ("worst_err_x_c", "worst |Δx_c| / (T/2)"), ("median_err_x_c", "median |Δx_c| / (T/2)"),
                       ("worst_err_x_c_horizon", "worst |Δx_c| / (T/2) less the friction rows' horizon v_x dt"),
                       ("median_dt_err", "median change when the time step is halved, / (T/2)"),
                       ("min_contact", "least fraction of steps with every wheel on the ground"),
                       ("unsteady", "cases not steady in their window")):
        table.add(label, number(fid, f"{p}/{key}"))
    table.add("worst change when the time step is halved, / (T/2)", number(fid, f"{p}/worst_dt_err/value"))
    tol = Table("Tolerances of the grid, as stored with the results.", ["tolerance", "value"])
    for key in fid.data["tolerances"]:
        tol.add(key, number(fid, f"/tolerances/{key}"))
    rt = Table("Real-time factor of one wheeled robot and of the default tracked robot, random steps, one thread "
               "(per CPU second of the process, and per wall second).",
               ["robot", "path", "time step [s]", "contacts", "per CPU second", "per wall second"])
    for robot in speed.data["results"]:
        for path in ("rollout", "simulate", "mj_step"):
            q = f"/results/{robot}/{path}"
            if path in speed.data["results"][robot]:
                rt.add(robot, path, number(speed, f"/results/{robot}/timestep"),
                       number(speed, f"/results/{robot}/contacts"), number(speed, q + "/realtime_factor_cpu"),
                       number(speed, q + "/realtime_factor_wall"))
    load = Table("Machine load during the speed run (one-minute load average).", ["when", "load"])
    load.add("before", number(speed, "/load_average_before/0"))
    load.add("after", number(speed, "/load_average_after/0"))
    return Page(
        "wheeled", "Wheeled robots",
        "The wheeled skid-steer robot (robot key `traction`: `wheels`) against the Coulomb reference that puts one "
        "point contact under each axle and knows that wheels can roll without slipping, and its speed. The grid "
        "covers robots with two and three wheels a side, light to heavy, with centre-of-mass offsets and split "
        "friction, pivots to gentle turns, slow to fast, both directions, forward and reverse.",
        [fid, speed], [table, tol, rt, load])


WHEELED_MODEL_NAMES = {"kinematic": "kinematic", "dynamic1": "dynamic 1", "dynamic2": "dynamic 2",
                       "skidsteer4": "four-wheel skid steer"}
AGREE = 0.02  # relative difference below which two ratios are said to agree "within two per cent"


def _ordinal(i: int, n: int) -> str:
    """Words for the i-th of n horizons, shortest first."""
    return "shortest" if i == 0 else "longest" if i == n - 1 else ("second", "third", "fourth", "fifth")[i - 1]


def _wheeled_models_intro(src: Source) -> str:
    """The page's "where and why", every statement computed from the result file."""
    cases = src.data["cases"]
    names = WHEELED_MODEL_NAMES
    hs = [f"{h:g}" for h in src.data["horizons_s"]]
    longest = hs[-1]
    best = {(c, h, what): v["wheeled_models"]["best"][h][what] for c, v in cases.items() for h in hs
            for what in ("position", "heading", "position_worst")}
    text = ["The wheeled-robot thesis's four models (kinematic differential drive, dynamic models 1 and 2, "
            "four-wheel skid steer) predict the wheeled MuJoCo robot's motion from the logged state at each window "
            "start (`mjtrack validate` on a wheeled robot). Where:"]
    for what, words in (("position", "median position error"), ("heading", "median heading error"),
                        ("position_worst", "worst position error")):
        won = [best[k] for k in best if k[2] == what]
        top = max(set(won), key=won.count)
        others = [f"{c} at the {_ordinal(i, len(hs))} horizon ({names.get(best[(c, h, what)], 'none')})"
                  for c in cases for i, h in enumerate(hs) if best[(c, h, what)] != top]
        text.append(f"the {names.get(top, 'none')} has the lowest {words} in every case at every horizon"
                    + (f" except {', '.join(others)};" if others else ";"))
    order = "; ".join(f"{c}: " + ", ".join(names[k] for k in sorted(
        v["wheeled_models"]["models"], key=lambda k: v["wheeled_models"]["models"][k]["horizons"][longest]["pos_median_m"]))
        for c, v in cases.items())
    text.append(f"at the longest horizon the order by median position error is {order}.")
    agree = all(abs(v["yaw_rate_over_no_slip_median"] - v["skid_steer_slow_spin_ratio"])
                <= AGREE * v["skid_steer_slow_spin_ratio"] for v in cases.values())
    grows = all(all(a < b for a, b in zip(seq, seq[1:])) for v in cases.values()
                for k in ("kinematic", "dynamic1", "dynamic2")
                for seq in [[v["wheeled_models"]["models"][k]["horizons"][h]["yaw_median_deg"] for h in hs]])
    text.append("Why: in a turn the logged robot's yaw rate is a fraction of the no-slip rate (V_R − V_L)/T "
                "(last table), " + ("within two per cent of" if agree else "not everywhere close to") +
                " the four-wheel model's slow-spin ratio b²/(a² + b²): both axles' wheels skid sideways. The "
                "kinematic model and dynamic models 1 and 2 have two wheels on one axle and no wheelbase, so in a "
                "steady turn they turn at, or close to, the no-slip rate" + (
                    ", and their median heading error grows with the horizon in every case." if grows else "."))
    return " ".join(text)


def _wheeled_models() -> Page:
    src = Source(RESULTS / "wheeled_models.json")
    hs = [f"{h:g}" for h in src.data["horizons_s"]]
    names = WHEELED_MODEL_NAMES
    tables = []
    for case, v in src.data["cases"].items():
        t = Table(f"{case}: prediction error of each model against the horizon, median and worst over the windows "
                  "(position at the robot's geometric centre).",
                  ["model", "horizon [s]", "position median [m]", "position worst [m]", "heading median [deg]",
                   "heading worst [deg]", "windows"])
        for key in v["wheeled_models"]["models"]:
            for i, h in enumerate(hs):
                q = f"/cases/{case}/wheeled_models/models/{key}/horizons/{h}"
                t.add(names[key], number(src, f"/horizons_s/{i}"), number(src, q + "/pos_median_m"),
                      number(src, q + "/pos_max_m"), number(src, q + "/yaw_median_deg"), number(src, q + "/yaw_max_deg"),
                      number(src, q + "/n"))
        tables.append(t)
    rank = Table("The best model per case and horizon (lowest median position, median heading, worst position "
                 "error).", ["case", "horizon [s]", "median position", "median heading", "worst position"])
    for case, v in src.data["cases"].items():
        for i, h in enumerate(hs):
            b = v["wheeled_models"]["best"][h]
            rank.add(case, number(src, f"/horizons_s/{i}"), names.get(b["position"], "none"),
                     names.get(b["heading"], "none"), names.get(b["position_worst"], "none"))
    why = Table("Yaw rate of the log over the no-slip rate (V_R − V_L)/T (median over the turning samples) and "
                "the four-wheel skid steer's slow-spin ratio b²/(a² + b²) (a wheelbase, b gauge).",
                ["case", "log: yaw rate / no-slip rate", "b²/(a² + b²)", "duration [s]"])
    for case in src.data["cases"]:
        why.add(case, number(src, f"/cases/{case}/yaw_rate_over_no_slip_median"),
                number(src, f"/cases/{case}/skid_steer_slow_spin_ratio"), number(src, f"/cases/{case}/duration_s"))
    load = Table("Machine load during the run (one-minute load average; the errors do not depend on it).",
                 ["when", "load"])
    load.add("before", number(src, "/load_average_before/0"))
    load.add("after", number(src, "/load_average_after/0"))
    return Page("wheeled_models", "Wheeled-robot models against the wheeled robot", _wheeled_models_intro(src),
                [src], [rank, *tables, why, load])


def _controllers() -> Page:
    src = Source(RESULTS / "controllers.json")
    tables = []
    for robot, data in src.data["figure_eight"].items():
        t = Table(f"Figure-eight, {robot} MuJoCo robot against the same controller on the kinematic model: cross-track "
                  "error [m] (RMS and maximum); MuJoCo with exact measurements, and with measurement noise (mean of "
                  "the RMS and worst maximum over the noise seeds).",
                  ["controller", "kinematic RMS", "kinematic max", "MuJoCo RMS", "MuJoCo max", "noisy mean RMS",
                   "noisy worst max"])
        for name in data["controllers"]:
            q = f"/figure_eight/{robot}/controllers/{name}"
            kin = ([number(src, q + "/kinematic/rms_cross_track_m"), number(src, q + "/kinematic/max_cross_track_m")]
                   if "kinematic" in data["controllers"][name] else ["–", "–"])  # the tracker has no kinematic run
            t.add(name, *kin,
                  number(src, q + "/mujoco_exact/rms_cross_track_m"), number(src, q + "/mujoco_exact/max_cross_track_m"),
                  number(src, q + "/mujoco_noisy_summary/mean_rms_cross_track_m"),
                  number(src, q + "/mujoco_noisy_summary/worst_max_cross_track_m"))
        tables.append(t)
    load = Table("Machine load during the run (one-minute load average) and its wall time [s].", ["when", "value"])
    load.add("load before", number(src, "/load_average_before/0"))
    load.add("load after", number(src, "/load_average_after/0"))
    load.add("wall time [s]", number(src, "/wall_s"))
    grid = Source(RESULTS / "compensation_grid.json")
    comp = Table("The slip compensation over a grid of cases (paths, friction, centre of mass, speed, noise seeds; "
                 "the tracker with each compensation against none): cases where it is not worse than none in RMS and in "
                 "maximum, and the ratio of its cross-track error to none's (below one: better).",
                 ["compensation", "cases", "not worse", "median RMS ratio", "worst RMS ratio", "median max ratio",
                  "worst max ratio"])
    for mode in grid.data["summary"]:
        q = f"/summary/{mode}"
        comp.add(mode, number(grid, q + "/cases"), number(grid, q + "/passed"), number(grid, q + "/median_rms_ratio"),
                 number(grid, q + "/worst_rms_ratio"), number(grid, q + "/median_max_ratio"),
                 number(grid, q + "/worst_max_ratio"))
    tables.append(comp)
    return Page(
        "controllers", "Path controllers",
        "The thesis's five path controllers (feed-forward, pole placement, reactive, posture, line following) and the "
        "slip-compensated tracker drive a figure-eight through `mjtrack track`, on the tracked and on the wheeled "
        "MuJoCo robot, and on the kinematic model they were designed for. The feed-forward controller is open loop: "
        "on the MuJoCo robot, whose tracks slip, nothing corrects its drift through the thesis's adapter "
        "(V = v -+ w T/2); through the slip compensation vir (feedforward_vir: the inverse of the online ICR "
        "estimate, `mjtrack track`'s default for it) its commands account for the slip: with exact measurements it "
        "follows the path, with measurement noise its estimate of the slip is noisy and it strays further (the "
        "noisy columns). Started from the Coulomb reference's steady ICRs of the robot's description "
        "(feedforward_coulomb: `mjtrack track --reference-map coulomb`), the compensation predicts the slip from the "
        "physics, and the open-loop feed-forward follows the path with or without measurement noise.",
        [src, grid], [*tables, load])


def _battery_cases(bat: Source, caption: str) -> tuple[Table, Table]:
    """The battery's per-case table and its every-candidate table."""
    cases = Table(caption, ["case", "causes named", "true cause first", "covered", "determined", "test before",
                            "test after", "diagnose, described", "diagnose, calibrated"])
    rows = Table("Every candidate of every battery case of the table above: truth, calibrated value (the described "
                 "value where kept), interval, whether the log determines it and whether the interval covers the truth.",
                 ["case", "parameter", "truth", "value", "interval low", "interval high", "determined", "covered"])
    for name, c in bat.data["cases"].items():
        q = f"/cases/{pointer_token(name)}"
        cases.add(name, "; ".join("+".join(g["parameters"]) for g in c["causes"]) or "none",
                  number(bat, q + "/cause_ok"), number(bat, q + "/rows", reduce="count", field_name="covered"),
                  number(bat, q + "/rows", reduce="count", field_name="determined"), number(bat, q + "/test/0"),
                  number(bat, q + "/test/1"), c.get("diagnose", {}).get("cause", "–"),
                  c.get("diagnose_calibrated", {}).get("cause", "–"))
        for i, x in enumerate(c["rows"]):
            r = f"{q}/rows/{i}"
            iv = ([number(bat, r + "/interval/0"), number(bat, r + "/interval/1")] if x.get("interval") else ["–", "–"])
            rows.add(name, x["parameter"], number(bat, r + "/truth"), number(bat, r + "/estimate"), *iv,
                     number(bat, r + "/determined"), number(bat, r + "/covered"))
    return cases, rows


def _battery_other_inputs(sources: list[Source], bat: Source) -> Table:
    """Battery cases calibrated with another drive input than calibrate's default, beside the same
    cases with the default (benchmarks/calibration_battery.py --drive-input fitted|measured)."""
    table = Table("Why calibrate's default drive input fits the drivetrain to the measured track speeds first only "
                  "when they show a capping speed controller: battery cases (the logs of the table above, whose "
                  "drives follow their commands through a lag, a delay and a speed scale) calibrated with "
                  "`--drive-input fitted` (the drivetrain fitted to the simulated track speeds first: its "
                  "wheel-speed RMS after its fit, left and right [m/s]) and with `--drive-input measured` (the "
                  "drives follow the simulated track speeds themselves): what the contact's fit then names, and the "
                  "held-out position error [m] before and after; the default's error after on the same case beside. "
                  "With either, the truth's lag, delay and speed scale are not the contact's candidates (the "
                  "drivetrain's, or the measured speeds', and the contact's speed scale is an effective rolling "
                  "radius, whose truth is one), so the battery's coverage and cause criteria do not apply.",
                  ["case", "drive input", "wheel-speed RMS, left", "wheel-speed RMS, right", "causes named",
                   "test before", "test after", "default: test after"])
    for src in sources:
        for name, c in src.data["cases"].items():
            key = pointer_token(name)
            q = f"/cases/{key}"
            speeds = ([number(src, q + "/drivetrain/wheel_speed_rms_after/0"),
                       number(src, q + "/drivetrain/wheel_speed_rms_after/1")] if "drivetrain" in c else ["–", "–"])
            table.add(name, str(c.get("drive_input_mode", "–")), *speeds,
                      "; ".join("+".join(g["parameters"]) for g in c["causes"]) or "none",
                      number(src, q + "/test/0"), number(src, q + "/test/1"),
                      number(bat, f"/cases/{key}/test/1") if name in bat.data["cases"] else "–")
    return table


def _calibration() -> Page:
    bat = Source(RESULTS / "calibration_battery.json")
    noisy_path = RESULTS / "calibration_battery_noisy.json"
    noisy = Source(noisy_path) if noisy_path.exists() else None
    real = Source(RESULTS / "real_robots.json")
    totals = Table("The battery's two criteria over all its cases: the true cause named first, and the share of "
                   "determined parameters whose interval (calibrate's, at its stated level) covers the truth; on noise-free "
                   "logs and on logs with "
                   "the measurement noise of the shared real robots (`mjtrack simulate --noise realistic`: poses, "
                   "yaw, track speeds, body velocity and yaw rate).",
                   ["logs", "cases", "true cause first", "determined parameters", "covered", "coverage"])
    for label, src in (("noise-free", bat), ("realistic noise", noisy)):
        if src is not None:
            totals.add(label, number(src, "/summary/cases"), number(src, "/summary/causes_right"),
                       number(src, "/summary/determined"), number(src, "/summary/covered"),
                       number(src, "/summary/coverage"))
    cases, rows = _battery_cases(
        bat, "The self-consistency battery: MuJoCo logs with one known change each (a minute of random steps; "
             "training and test logs of different seeds), calibrated from the description without the change. "
             "Causes: the parameter groups named, largest first; covered: determined parameters whose interval "
             "holds the truth; held-out position error [m] at the window's end before and after; the cause "
             "`diagnose --baseline mujoco` names against the description and against the calibrated robot.")
    battery = [totals, cases, rows]
    if noisy is not None:
        battery += list(_battery_cases(
            noisy, "The same battery on logs with realistic measurement noise (`--noise realistic`, the levels in "
                   "the next table; each log's noise from its own seed)."))
        levels = Table("The measurement noise of the noisy battery's logs: standard deviation of the white noise on "
                       "each measured channel.", ["channel", "standard deviation"])
        for channel, unit in noisy.data["noise_levels"]["units"].items():
            levels.add(f"{channel} [{unit}]", number(noisy, f"/noise_levels/std/{channel}"))
        battery.append(levels)
    other_inputs = [Source(p) for p in (RESULTS / f"calibration_battery_{mode}.json" for mode in ("fitted", "measured"))
                     if p.exists()]
    if other_inputs:
        battery.append(_battery_other_inputs(other_inputs, bat))
    following_path = RESULTS / "speed_following.json"
    following = Source(following_path) if following_path.exists() else None
    if following is not None:
        table = Table("Where the speed-following drives' error comes from: the MuJoCo robot as it is (the battery's "
                      "clean case of each geometry), its own log at two log rates, its 2 s windows driven by its "
                      "logged commands and by its own logged track speeds (the drives of `--drive-input measured`), "
                      "those read as logged and half a row and a row ahead: RMS over the windows of the end "
                      "position [m] and yaw [rad] error against the log.",
                      ["geometry", "log rate [Hz]", "drive", "speeds read ahead [rows]", "windows", "position [m]",
                       "yaw [rad]"])
        for i, r in enumerate(following.data["rows"]):
            q = f"/rows/{i}"
            table.add(r["geometry"], number(following, q + "/rate_hz"), r["drive"],
                      "–" if r["lead_rows"] is None else number(following, q + "/lead_rows"),
                      number(following, q + "/windows"), number(following, q + "/position_rms_m"),
                      number(following, q + "/yaw_rms_rad"))
        table.add("load average before / after (one minute)", number(following, "/load_before/0"),
                  number(following, "/load_after/0"), "–", "–", "–", "–")
        battery.append(table)
    robots = Table("Three real robots, calibrated on the first part of their log and scored on the next part: held-out "
                   "position error [m] at the window's end before and after, its relative drop, the steady-turn yaw ratio "
                   "(yaw rate over the ideal (v_R - v_L)/T) measured and simulated on the test part, and the windows "
                   "left out because the ground cannot explain them: poses that move against the tracks, or a robot "
                   "held still while a track ran under it (calibration.json `left_out`).",
                   ["robot", "train windows", "test windows", "test before", "test after", "drop", "yaw ratio measured",
                    "simulated before", "simulated after", "left out, train", "left out, test"])
    context = Table("What puts the real robots' test errors [m] in context, on the same windows: a kinematic ICR model "
                    "(speed scale, effective gauge, ICR offset) driven by the measured track speeds, fitted on the "
                    "training windows (a baseline) and on the test windows themselves (a bound no model of that family "
                    "can beat there); the described robot with every window started with the body at rest instead of "
                    "the twist estimated from the poses; the calibrated robot's median window error and the share of "
                    "its squared error carried by its ten worst windows; the described and calibrated robots' error "
                    "over every test window, the windows left out included, and its relative drop.",
                    ["robot", "calibrated MuJoCo", "kinematic, fitted on train", "kinematic, fitted on test",
                     "described MuJoCo", "described, started at rest", "calibrated, median window",
                     "ten worst windows' share", "every window: described", "every window: calibrated",
                     "every window: drop"])
    params = Table("Every candidate of the real-robot calibrations: described value, calibrated value, interval, "
                   "whether the log determines it and whether calibration changed it.",
                   ["robot", "parameter", "described", "calibrated", "interval low", "interval high", "determined",
                    "changed"])
    class_names = _turn_class_names()
    speed = Table("Forward speed over the mean track speed in steady windows of the test part, by turn class "
                  "of |turn ratio| = |v_R - v_L| / (|v_L| + |v_R|) (straight, turning, sharp turns: the classes of the "
                  "forward speed ratio findings in calibration.json), measured and simulated before and after calibration: "
                  "1 when the body keeps up with its tracks (Coulomb contact alone); real robots fall behind in turns "
                  "when the ground resists their motion (robot key `rolling_resistance`).",
                  ["robot", "turn class", "windows", "measured", "simulated before", "simulated after"])
    by_sample = Table("The yaw ratio over every sample of the test windows, not only their steady turns: per |turn "
                      "ratio| class of the measured track speeds, the least-squares gain of the yaw rate on the ideal one "
                      "((v_R - v_L) / T, each of its own track speeds; samples below the steady-turn floor of ideal yaw "
                      "rate left out), measured and by the calibrated robot on the same samples (`yaw_by_sample` of "
                      "benchmarks/real_robots.py). Beside the steady turns' classes above: what the poses of every "
                      "window ask of the robot.",
                      ["robot", "|turn ratio| from", "to", "samples", "measured", "calibrated"])
    summaries = Table("The causes each calibration names (parameter groups, largest first), how its simulated drives "
                      "were driven, and what `diagnose --baseline mujoco` still finds on the test part against the "
                      "calibrated robot.", ["robot", "causes named", "drives follow", "diagnosis of the calibrated robot"])
    for name, r in real.data["robots"].items():
        q = f"/robots/{name}"
        robots.add(name, number(real, q + "/windows/train"), number(real, q + "/windows/test"),
                   number(real, q + "/test/before"), number(real, q + "/test/after"), number(real, q + "/test/relative"),
                   number(real, q + "/yaw_ratio/measured"), number(real, q + "/yaw_ratio/before"),
                   number(real, q + "/yaw_ratio/after"),
                   *(number(real, f"{q}/left_out/{part}/windows", reduce="length") if part in r.get("left_out", {})
                     else ("none" if "left_out" in r else "not checked") for part in ("train", "test")))
        if "kinematic" in r:
            context.add(name, number(real, q + "/test/after"), number(real, q + "/kinematic/fitted_on_train/rms"),
                        number(real, q + "/kinematic/fitted_on_test/rms"), number(real, q + "/test/before"),
                        number(real, q + "/start_at_rest/rms"), number(real, q + "/concentration/median_m"),
                        number(real, q + "/concentration/share"),
                        *(number(real, q + f"/with_left_out/{k}") if "with_left_out" in r else "not computed"
                          for k in ("before", "after", "relative")))
        for k, row in enumerate(r.get("yaw_by_sample", [])):
            p = f"{q}/yaw_by_sample/{k}"
            by_sample.add(name, number(real, p + "/turn_class/0"), number(real, p + "/turn_class/1"),
                          number(real, p + "/samples"),
                          *(number(real, p + f"/{key}") if row[key] is not None else "–" for key in ("measured", "simulated")))
        for cls in r.get("speed_ratio", {}):
            p = f"{q}/speed_ratio/{pointer_token(cls)}"
            speed.add(name, class_names.get(cls, cls), number(real, p + "/windows"), number(real, p + "/measured"),
                      number(real, p + "/before"), number(real, p + "/after"))
        for n in r["determined"]:
            iv = ([number(real, f"{q}/intervals/{n}/0"), number(real, f"{q}/intervals/{n}/1")]
                  if r["intervals"].get(n) else ["–", "–"])
            params.add(name, n, number(real, f"{q}/described/{n}"), number(real, f"{q}/parameters/{n}"), *iv,
                       number(real, f"{q}/determined/{n}/determined"), number(real, f"{q}/determined/{n}/changed"))
        summaries.add(name, "; ".join("+".join(g["parameters"]) for g in r["causes"]) or "none",
                      f"{r.get('drive_input', 'commanded')} track speeds",
                      r["diagnose"]["cause"] if "diagnose" in r else "not run")
    starts_path = RESULTS / "start_independence.json"
    starts_tables = []
    if starts_path.exists():
        st = Source(starts_path)
        agree = Table("Does the answer hang on the start? Each robot calibrated with calibrate's default windows, "
                      "and the drive input of the reference run above, from the description shipped with its log "
                      "(gauge and sprocket radius; every other key a default) and from the public specification, "
                      "on the held-out split of `python benchmarks/real_robots.py --starts` (its docstring): every "
                      "candidate's two values, whether both calibrations determine it and, if so, whether each "
                      "value lies in the other's interval (a value beyond the other description's search range, "
                      "which follows its geometry, compared with the nearest end of that range), and the weaker "
                      "reading: whether their difference lies within its own interval (the two half-widths added in "
                      "quadrature). An interval that allows for parameters held at a default the description does "
                      "not give and the log does not determine names them (the concepts page, \"Defaults are not "
                      "information\").",
                      ["robot", "parameter", "from shipped", "from public", "determined in both",
                       "each in the other's interval", "difference within its interval", "compared",
                       "interval allows for (shipped; public)"])
        errs = Table("The two calibrations of the table above: held-out position error [m] at the window's end "
                     "before and after, the wall time of the calibration [s] (the load is in the result file) and "
                     "the causes each names, largest share first (not plausible: said as something no candidate "
                     "describes, never as a cause).",
                     ["robot", "start", "drive input", "rounds", "test before", "test after", "seconds",
                      "causes named"])
        turning = Table("Do the two calibrations of the table above turn alike? Per turn class with enough steady "
                        "windows of the test part (the classes of the yaw table above), the measured yaw ratio, "
                        "each calibrated robot's, and whether the two lie within the criterion's gap of each other "
                        "(the turn candidates are fixed together by the steady turns, not one by one, so their "
                        "intervals are wide and the parameter table alone cannot tell); each one's bootstrap interval "
                        "(calibrate's level) of measured minus calibrated over the class's test windows (how finely the class's "
                        "few windows resolve the gap); with whether calibrate's turn stage ran and was taken from "
                        "each description.",
                        ["robot", "class", "test windows", "measured", "from shipped", "from public", "alike",
                         "shipped: gap low", "shipped: gap high", "public: gap low", "public: gap high",
                         "turn stage (shipped; public)"])
        words = {k.removeprefix("(|turn ratio| ").removesuffix(")"): v for k, v in _turn_class_names().items()}
        for name, r in st.data["robots"].items():
            q = f"/robots/{name}"
            stage = "; ".join(_stage_words(r["starts"][s_].get("turn_stage")) for s_ in ("shipped", "public"))
            for c in r.get("turning") or {}:
                t = f"{q}/turning/{c}"
                gaps = (r["turning"][c].get("gap_interval") or {})
                turning.add(name, words.get(c, c), number(st, t + "/windows"), number(st, t + "/measured"),
                            number(st, t + "/shipped"), number(st, t + "/public"), number(st, t + "/within_gap"),
                            *(number(st, f"{t}/gap_interval/{s_}/{k}") if gaps.get(s_) else "–"
                              for s_ in ("shipped", "public") for k in (0, 1)),
                            stage)
            for n in r["agreement"]:
                a = f"{q}/agreement/{n}"
                agree.add(name, n, number(st, a + "/shipped"), number(st, a + "/public"),
                          number(st, a + "/determined_in_both"),
                          number(st, a + "/each_in_the_other_interval"),
                          number(st, a + "/difference_within_its_interval")
                          if "difference_within_its_interval" in r["agreement"][n] else "–",
                          ("per kg of each description's mass" if "per_kg" in r["agreement"][n] else "as fitted")
                          + ("; beyond the other's range: compared with its end"
                             if r["agreement"][n].get("beyond_the_other_range") else ""),
                          "; ".join(", ".join(r["starts"][s_]["determined"].get(n, {}).get("allows_for", [])) or "–"
                                    for s_ in ("shipped", "public")))
            for start, x in r["starts"].items():
                named = ["+".join(g["parameters"]) + ("" if g.get("plausible", True) else " (not plausible)")
                         for g in x["causes"]]
                errs.add(name, start, x.get("drive_input", "commanded"),
                         number(st, f"{q}/rounds") if "rounds" in r else "calibrate's default",
                         number(st, f"{q}/starts/{start}/test/before"),
                         number(st, f"{q}/starts/{start}/test/after"), number(st, f"{q}/starts/{start}/seconds"),
                         "; ".join(named) or "none")
        starts_tables = [agree, errs] + ([turning] if turning.rows else [])
    written = [real.path.parent / "real_robots" / name / f for name in real.data["robots"]
               for f in ("robot.json", "calibration.json", "report.html")]
    yaw_sources, yaw = [], Table(
        "Steady-turn yaw ratio per |turn ratio| class on the training and the held-out windows of the calibrations "
        "above (each robot's calibration.json, findings): measured, as described, calibrated, and the bootstrap "
        "interval over the windows of measured minus calibrated (how far the class's few windows alone move the "
        "gap). Where a class's measured ratio differs between the two parts, no calibration on the first can "
        "follow the second.",
        ["robot", "part", "|turn ratio| from", "to", "windows", "measured", "described robot", "calibrated",
         "gap interval, low", "gap interval, high"])
    coulomb_path = RESULTS / "real_robots_coulomb.json"
    coulomb = Source(coulomb_path) if coulomb_path.exists() else None
    runs = [(name, real.path.parent / "real_robots" / name / "calibration.json") for name in real.data["robots"]]
    if coulomb is not None:
        runs += [(f"{name}, without shear_modulus", real.path.parent / "real_robots_coulomb" / name / "calibration.json")
                 for name in coulomb.data["robots"]]
        written += [real.path.parent / "real_robots_coulomb" / name / f for name in coulomb.data["robots"]
                    for f in ("robot.json", "calibration.json", "report.html")]
    lateral_path = RESULTS / "real_robots_lateral.json"
    lateral = Source(lateral_path) if lateral_path.exists() else None
    if lateral is not None:
        runs += [(f"{name}, with lateral_shear_ratio", real.path.parent / "real_robots_lateral" / name / "calibration.json")
                 for name in lateral.data["robots"]]
        written += [real.path.parent / "real_robots_lateral" / name / f for name in lateral.data["robots"]
                    for f in ("robot.json", "calibration.json", "report.html")]
    advanced_path = RESULTS / "real_robots_advanced.json"
    advanced = Source(advanced_path) if advanced_path.exists() else None
    if advanced is not None:
        written += [real.path.parent / "real_robots_advanced" / name / f for name in advanced.data["robots"]
                    for f in ("robot.json", "calibration.json", "report.html")]
    for name, path in runs:
        if not path.exists():
            continue
        cal = Source(path)
        rows = [(k, f) for k, f in enumerate(cal.data["findings"]) if f.get("turn_class") and f.get("gap_after_interval")]
        rows.sort(key=lambda kf: kf[1]["part"] != "train")  # training part first, as the fit saw it
        if rows:
            yaw_sources.append(cal)
        for k, f in rows:
            q = f"/findings/{k}"
            yaw.add(name, f["part"], number(cal, q + "/turn_class/0"), number(cal, q + "/turn_class/1"), number(cal, q + "/windows"),
                    number(cal, q + "/measured"), number(cal, q + "/simulated_before"),
                    number(cal, q + "/simulated_after"), number(cal, q + "/gap_after_interval/0"),
                    number(cal, q + "/gap_after_interval/1"))
    scatter_path = RESULTS / "yaw_class_scatter.json"
    scatter_tables, scatter_sources = [], []
    if scatter_path.exists():
        sc = Source(scatter_path)
        scatter_sources.append(sc)
        scatter_names = _turn_class_names()
        t = Table("How far a turn class's measured steady yaw ratio moves by itself along a log, nothing simulated "
                  "(`python benchmarks/real_robots.py --class-scatter`, its docstring): each log cut into consecutive "
                  "parts of equal segment counts; per class, the parts with enough steady turns, their typical "
                  "number of turns, the lowest and highest part median and the standard deviation of the part "
                  "medians. A calibrated robot cannot follow a class closer than its own measurement moves.",
                  ["robot", "turn class", "parts", "steady turns per part (median)", "lowest median",
                   "highest median", "standard deviation"])
        for name, r in sc.data["robots"].items():
            for cls, c in r["classes"].items():
                q = f"/robots/{name}/classes/{cls}"
                lo, _, hi = cls.partition("-")
                t.add(name, scatter_names.get(f"(|turn ratio| {lo} to {hi})", cls), number(sc, q + "/parts"), number(sc, q + "/median_turns"), number(sc, q + "/lowest"),
                      number(sc, q + "/highest"),
                      number(sc, q + "/sd_of_medians") if c["sd_of_medians"] is not None else "–")
        scatter_tables.append(t)
    turn_tables, turn_sources = _turn_stage_tables(
        [(name, real.path.parent / "real_robots" / name / "calibration.json") for name in real.data["robots"]])
    shear_tables = []
    if coulomb is not None:
        t = Table("What the shear ground buys the wheeled robots: their reference calibrations above fit the shear "
                  "ground's modulus `shear_modulus` (a wheeled robot's default candidate; K = 0 is the Coulomb ground "
                  "they are described on); the same calibrations without it (`--coulomb`), on the same split: the "
                  "held-out position error at the window's end [m] before and after each, and K with its interval "
                  "where the log determines it.",
                  ["robot", "held-out before", "after, with shear_modulus", "after, without", "K [m]",
                   "K interval, low", "K interval, high", "K determined", "seconds with", "seconds without"])
        for name, r in real.data["robots"].items():
            if "shear_modulus" not in r["parameters"] or name not in coulomb.data["robots"]:
                continue
            q = f"/robots/{name}"
            iv = r["intervals"].get("shear_modulus")
            t.add(name, number(real, q + "/test/before"), number(real, q + "/test/after"),
                  number(coulomb, q + "/test/after"), number(real, q + "/parameters/shear_modulus"),
                  number(real, q + "/intervals/shear_modulus/0") if iv else "–",
                  number(real, q + "/intervals/shear_modulus/1") if iv else "–",
                  "yes" if r["determined"]["shear_modulus"]["determined"] else "no",
                  number(real, q + "/seconds"), number(coulomb, q + "/seconds"))
        shear_tables.append(t)
    if lateral is not None:
        t = Table("What different shear moduli along and across buy the wheeled robots: the reference calibrations "
                  "with the shear ground's `lateral_shear_ratio` (the modulus across the tyre over the one along it) "
                  "among the candidates as well (`--lateral`), on the same split: the held-out position error at the "
                  "window's end [m] after, with and without it, the ratio and the modulus with their intervals where "
                  "the log determines them.",
                  ["robot", "after, without the ratio", "after, with it", "ratio", "ratio interval, low",
                   "ratio interval, high", "ratio determined", "K [m] with it", "seconds with it"])
        for name, r in lateral.data["robots"].items():
            if name not in real.data["robots"]:
                continue
            q = f"/robots/{name}"
            iv = r["intervals"].get("lateral_shear_ratio")
            t.add(name, number(real, q + "/test/after"), number(lateral, q + "/test/after"),
                  number(lateral, q + "/parameters/lateral_shear_ratio"),
                  number(lateral, q + "/intervals/lateral_shear_ratio/0") if iv else "–",
                  number(lateral, q + "/intervals/lateral_shear_ratio/1") if iv else "–",
                  "yes" if r["determined"]["lateral_shear_ratio"]["determined"] else "no",
                  number(lateral, q + "/parameters/shear_modulus"), number(lateral, q + "/seconds"))
        shear_tables.append(t)
    if advanced is not None:
        t = Table("Whether the wheel speeds' clock is what the contact fit misses: the reference calibrations with each "
                  "log's measured track speeds taken later than logged by the time shown (`--advance-speeds`, as if "
                  "their clock were set by the gyro's; the timing table of the results page \"Real robots against "
                  "peers\"), on the same split: the held-out position error at the window's end [m] before and after, "
                  "as logged and advanced, the same error of a kinematic ICR model on the measured speeds fitted on "
                  "the training windows (the table of test errors in context), and the steady-turn yaw ratio on the "
                  "test windows, measured and calibrated.",
                  ["robot", "speeds taken later by [s]", "before, as logged", "after, as logged", "before, advanced",
                   "after, advanced", "kinematic, as logged", "kinematic, advanced", "yaw ratio measured",
                   "calibrated, as logged", "calibrated, advanced"])
        for name, r in advanced.data["robots"].items():
            if name not in real.data["robots"]:
                continue
            q = f"/robots/{name}"
            t.add(name, number(advanced, q + "/advance_speeds_s"), number(real, q + "/test/before"),
                  number(real, q + "/test/after"), number(advanced, q + "/test/before"),
                  number(advanced, q + "/test/after"), number(real, q + "/kinematic/fitted_on_train/rms"),
                  number(advanced, q + "/kinematic/fitted_on_train/rms"), number(real, q + "/yaw_ratio/measured"),
                  number(real, q + "/yaw_ratio/after"), number(advanced, q + "/yaw_ratio/after"))
        shear_tables.append(t)
    return Page(
        "calibration", "Calibration",
        "What `mjtrack calibrate` finds on logs whose truth is known (the MuJoCo robot's own logs, one change each), "
        "and on three real robots: Marmotte (tracked), Husky and Warthog (wheeled skid-steer), from the DRIVE data. "
        "A parameter the log does not determine keeps its described value and is marked so; intervals carry the "
        "correlation of a log's windows and the measured model-form error of simulating a window from a logged "
        "state.", [bat, *([noisy] if noisy is not None else []), *other_inputs,
                   *([following] if following is not None else []), real, *([coulomb] if coulomb is not None else []),
                   *([lateral] if lateral is not None else []), *([advanced] if advanced is not None else []),
                   *([Source(starts_path)] if starts_path.exists() else []), *yaw_sources,
                   *[c for c in turn_sources if c.path not in {y.path for y in yaw_sources}], *scatter_sources],
        [*battery, robots, context, speed, params, summaries, *turn_tables, *shear_tables,
         *([yaw] if yaw_sources else []), *scatter_tables,
         *([by_sample] if by_sample.rows else []),
         *starts_tables],
        written=[p for p in written if p.exists()])


#: the turn stage's outcome (calibration.json ``method.turns.refused_by``) in the page's words
TURN_REFUSALS = {None: "it turns as the log does, and the training part's steady turns and end poses together speak "
                       "less against it than against the fit's robot",
                 "turns": "no value of the turn candidates turns as the log does in every class",
                 "bound": "turning as the log does takes a candidate to a bound of its range",
                 "diverges": "the robot that turns as the log does diverges in more training windows",
                 "end_poses": "the training windows' end poses speak more against it than the steady turns against "
                              "the fit's robot"}


def _refit_words(refit: dict | None) -> str:
    """The turn stage's refit of the other values (``method.turns.refit``) in words."""
    if refit is None:
        return "not run"
    if refit["kept"]:
        return "yes, that robot is judged"
    why = ("the refit puts a value on a bound of its range where the pose fit's did not" if refit.get("on_bound")
           else TURN_REFUSALS[refit["refused_by"]])
    return f"refused ({why}): the first turn-matched robot is judged"


def _stage_words(stage: dict | None) -> str:
    """A start comparison's record of calibrate's turn stage in words."""
    if stage is None:
        return "not recorded"
    if not stage["ran"]:
        return "not run"
    if stage["accepted"]:
        return "taken" + (", others refitted" if stage.get("refit_kept") else "")
    return f"refused ({TURN_REFUSALS[stage['refused_by']]})"


def _turn_stage_tables(runs: list[tuple[str, Path]]) -> tuple[list[Table], list[Source]]:
    """The turn stage of each real-robot calibration (calibration.json ``method.turns``): its outcome,
    and its classes measured / as fitted / turn-matched on the training part."""
    outcome = Table("Turning as the log does (the concepts page, \"Turning as the log does\"): when the pose fit's "
                    "robot turned unlike the training part's steady turns, the turn candidates fitted to them; whether "
                    "their values replaced the fit's and why, the position error at the window's end [m] of both robots "
                    "on every training window and on the test windows (never fitted), the least-squares "
                    "evaluations, whether the robot judged is the one whose other changed values were fitted "
                    "again to the end poses with the turn candidates held, and how strongly the training part speaks "
                    "against each robot (`evidence`: the Wald statistic of its steady turns' class medians plus the "
                    "squared z of the end poses where they show it the worse one; the lower is kept).",
                    ["robot", "ran", "accepted", "train: fit's robot", "train: turn-matched", "test: fit's robot",
                     "test: turn-matched", "evaluations", "others refitted", "against the fit's robot",
                     "against the turn-matched", "why"])
    class_names = _turn_class_names()
    classes = Table("The turn stage's classes on the training part (steady windows; the classes of the tables above: "
                    "straight, turning, sharp turns by |turn ratio|): measured, the pose fit's robot, the turn-matched "
                    "robot; and the turn candidates' values with their intervals (calibrate's level).",
                    ["robot", "quantity", "measured / value", "fit's robot / interval low", "turn-matched / interval high"])
    sources = []
    for name, path in runs:
        if not path.exists():
            continue
        cal = Source(path)
        t = cal.data["method"].get("turns")
        if t is None:
            outcome.add(name, "no", "–", "–", "–", "–", "–", "–", "–", "–", "–",
                        "the fitted robot turns as the log does in every class with enough steady turns")
            continue
        sources.append(cal)
        q = "/method/turns"
        test = t.get("test_rms_m")
        outcome.add(name, "yes", number(cal, q + "/accepted"), number(cal, q + "/train_rms_m/fitted"),
                    number(cal, q + "/train_rms_m/turn_matched"),
                    number(cal, q + "/test_rms_m/fitted") if test else "–",
                    number(cal, q + "/test_rms_m/turn_matched") if test else "–",
                    number(cal, q + "/evaluations"), _refit_words(t.get("refit")),
                    *((number(cal, f"{q}/evidence/chi2_{k}") for k in ("fit", "turn_matched")) if t.get("evidence")
                      else ("–", "–")),
                    TURN_REFUSALS[t.get("refused_by")])
        for k, label in enumerate(t["classes"]):
            quantity, _, cls = label.partition(" (")
            classes.add(name, f"{quantity}, {class_names.get('(' + cls, cls)}", number(cal, f"{q}/measured/{k}"),
                        number(cal, f"{q}/fitted/{k}"), number(cal, f"{q}/turn_matched/{k}"))
        for n in t["candidates"]:
            iv = t["intervals"].get(n)
            classes.add(name, n, number(cal, f"{q}/values/{n}"),
                        number(cal, f"{q}/intervals/{n}/0") if iv else "–",
                        number(cal, f"{q}/intervals/{n}/1") if iv else "–")
    return [outcome] + ([classes] if classes.rows else []), sources


#: the peer models of benchmarks/peers.py, in the order and words of the page
PEER_MODELS = {"drive": "DRIVE (the authors' dead time)", "drive_dead_time_fitted": "DRIVE, dead time fitted",
               "ideal_commands": "ideal diff-drive, commands", "ideal_measured": "ideal diff-drive, measured speeds",
               "icr_commands": "ICR model, commands", "icr_measured": "ICR model, measured speeds",
               "calibrated_mujoco": "calibrated MuJoCo robot"}


#: the models of the drives whose track speeds benchmarks/peers.py compares, in the page's words
WHEEL_SPEED_MODELS = {"drive": "DRIVE's powertrain", "chain_without_twist_ramps": "chain without the twist ramps",
                      "chain": "chain"}


def _peers() -> Page:
    from mjtrack.calibrate.measures import TURN_CLASSES

    src = Source(RESULTS / "peers.json")
    class_names = dict(zip((f"{lo:g}-{hi:g}" for lo, hi in TURN_CLASSES), ("straight", "turning", "sharp turns")))
    rep = Table("DRIVE fitted on every window of each whole shared log, beside the values the authors' code gives on "
                "the same log: powertrain time constant and dead time per side [s], slip weights on [v_x]; [v_x w]; "
                "[v_x w, v_x, w]. Ours on the authors' nominal clock (every sample taken one period of the nominal "
                "rate after the last, as their code takes them) and on the log's own times; and with the dead time "
                "fitted instead of left where the authors' optimiser leaves it.",
                ["robot", "fit", "tau left", "tau right", "dead time left", "dead time right", "w x", "w y",
                 "w yaw (v_x w)", "w yaw (v_x)", "w yaw (w)"])
    split = Table("The held-out split: shares of the log's segments for training and test (the same for the three "
                  "robots), windows of each part and those kept; a window the ground cannot explain (poses against the "
                  "tracks, or the robot held still under a running track) is left out for every model.",
                  ["robot", "train share", "test share", "train windows", "train kept", "test windows", "test kept",
                   "left out of test"])
    models = Table("Every model on the same held-out windows, each started from the window's measured pose: "
                   "end-of-window position error RMS [m], the mean over windows of the position distance averaged over "
                   "the window (the authors' metric) [m], end-of-window yaw error RMS [rad], and the steady-turn yaw "
                   "ratio (yaw rate over (v_R - v_L)/T of the measured track speeds, for every model: what it predicts of "
                   "the turn, its drives' error included) of the model and of the measurement. The calibration "
                   "page's yaw ratio of a simulation divides by the simulation's own track speeds (the contact "
                   "alone), so the two differ for the calibrated robot where its drives miss the measured speeds.",
                   ["robot", "model", "windows", "end RMS", "mean distance", "yaw RMS", "yaw ratio", "yaw ratio measured"])
    turns = Table("The steady-turn yaw ratio per class of |turn ratio| = |v_R - v_L| / (|v_L| + |v_R|) of the measured "
                  "track speeds (straight, turning, sharp turns: calibrate's classes of the forward speed ratio): "
                  "measured and per model, each over the measured track speeds as above; n/a where the class has no "
                  "steady turn fast enough to count.",
                  ["robot", "turn class", "steady turns", "measured", "model", "model's yaw ratio"])
    regions = Table("Prediction regions for the end position at the level shown, per model: fitted on the scatter of "
                    "its training windows' end errors (per turn class of the commands, growing with the commanded "
                    "path; mjtrack.metrics.fit_end_regions), the share of held-out windows whose measured end they "
                    "hold, the same share on the training windows, and their mean area [m^2].",
                    ["robot", "model", "level", "held-out coverage", "training coverage", "mean area"])
    speeds = Table("What each model of the drives predicts of the measured track speeds on the same held-out windows, "
                   "from the commands and the measured speeds at each window's start: DRIVE's powertrain, and the "
                   "drivetrain chain (`mjtrack.calibrate.drivetrain.fit_chain`, fitted on the training part) with and "
                   "without the twist controller's ramps. RMS of measured minus predicted [m/s] per side over every "
                   "window, over those that start with a command step (and among them, per side, those accelerating, "
                   "braking or reversing: the command ahead of, behind or against the start speed by more than "
                   "`regime_margin_m_s`) and over the steady ones; then, in the second half of steady windows, the mean "
                   "residual of the two sides' half difference (positive: the measured turn is larger) per class of "
                   "the commanded half difference (small, medium, large: `half_difference_classes_m_s` in the result "
                   "file), in the RMS left column.",
                   ["robot", "model", "regime", "windows left", "windows right", "RMS left", "RMS right"])
    gyro = Table("What the logs' gyros say beside their poses (`gyro_evidence` of benchmarks/peers.py), on each part "
                 "of the split: the steady-turn yaw ratio per turn class from the poses (as above) and from the gyro "
                 "(its mean rate over each steady turn over (v_R - v_L)/T of the measured track speeds; median over the "
                 "same windows): two sensors on one quantity.",
                 ["robot", "part", "turn class", "steady turns", "from the poses", "from the gyro"])
    lead = Table("When the body turns against when its measured track speeds say it should (`gyro_evidence` of "
                 "benchmarks/peers.py): over the windows of each part that start with a command step whose yaw rate "
                 "changes by at least `min_change_rad_s`, how long before the ideal yaw rate of the measured track "
                 "speeds, (v_R - v_L)/T, the gyro's rate gets half-way to its new value [s] (quartiles and median). "
                 "Positive: the body turns first, which says the measured speeds are dated late against the gyro. "
                 "Beside it, over every window of the part, how far the gyro's yaw rate and the poses' (their yaw "
                 "differentiated) run ahead of that ideal rate, from the shift of their highest cross-correlation "
                 "[s] (`xcorr`): the poses are what calibrate fits.",
                 ["robot", "part", "step windows timed", "25 %", "median", "75 %", "gyro ahead, cross-correlation",
                  "poses ahead, cross-correlation"])
    theirs = Table("The authors' DRIVE on the last part of each run, which the shared folders do not hold (other "
                   "windows than ours): end-of-window RMS [m], mean distance over the window [m], windows.",
                   ["robot", "end RMS", "mean distance", "windows"])
    for name, r in src.data["robots"].items():
        q = f"/robots/{name}"
        for fit in ("authors", "nominal_clock", "log_clock", "dead_time_fitted"):
            f = f"{q}/reproduction/{fit}"
            x = r["reproduction"][fit]
            w = ([number(src, f"{f}/slip_weights/{k}/{i}") for k, n in (("x", 1), ("y", 1), ("yaw", 3)) for i in range(n)]
                 if "slip_weights" in x else ["as above"] * 5)
            rep.add(name, {"authors": "the authors' code", "nominal_clock": "ours, nominal clock",
                           "log_clock": "ours, the log's times", "dead_time_fitted": "ours, dead time fitted"}[fit],
                    *(number(src, f"{f}/{k}/{i}") for k in ("tau", "delay") for i in (0, 1)), *w)
        split.add(name, number(src, q + "/split/train"), number(src, q + "/split/test"),
                  number(src, q + "/windows/train/windows"), number(src, q + "/windows/train/kept"),
                  number(src, q + "/windows/test/windows"), number(src, q + "/windows/test/kept"),
                  number(src, q + "/windows/test/left_out"))
        for m in PEER_MODELS:
            if m not in r["models"]:
                continue
            p = f"{q}/models/{m}"
            label = PEER_MODELS[m] + (f" (drives follow the {r['calibrated']['drive_input']} speeds)"
                                      if m == "calibrated_mujoco" and "calibrated" in r else "")
            g = f"{q}/regions/{m}"
            if m in r.get("regions", {}):
                regions.add(name, label, number(src, g + "/level"), number(src, g + "/coverage"),
                            number(src, g + "/train_coverage"), number(src, g + "/mean_area_m2"))
            models.add(name, label, number(src, p + "/windows"), number(src, p + "/end_rms_m"),
                       number(src, p + "/mean_distance_m"), number(src, p + "/yaw_rms_rad"),
                       number(src, f"{q}/yaw_ratio/all/{m}"), number(src, f"{q}/yaw_ratio/all/measured"))
        for cls, row in r["yaw_ratio"].items():
            if cls == "all":
                continue
            for m in PEER_MODELS:
                if m in row:
                    c = f"{q}/yaw_ratio/{cls}"
                    turns.add(name, class_names.get(cls, cls), number(src, c + "/windows"), number(src, c + "/measured"),
                              PEER_MODELS[m], number(src, f"{c}/{m}"))
        if "wheel_speeds" in r:
            w = f"{q}/wheel_speeds"
            for m, label in WHEEL_SPEED_MODELS.items():
                for regime in ("all", "step", "accelerating", "braking", "reversing", "steady"):
                    p = f"{w}/models/{m}/{regime}"
                    n = r["wheel_speeds"]["windows"].get(regime)
                    count = ([number(src, f"{w}/windows/{regime}/{i}") for i in (0, 1)] if isinstance(n, list) else
                             [number(src, f"{w}/windows/{regime}")] * 2 if n is not None else ["every", "every"])
                    speeds.add(name, label, regime, *count, number(src, p + "/0"), number(src, p + "/1"))
                for cls in r["wheel_speeds"]["models"][m]["steady_by_commanded_half_difference"]:
                    p = f"{w}/models/{m}/steady_by_commanded_half_difference/{cls}"
                    speeds.add(name, label, f"steady, {cls} turns: half-difference bias", number(src, p + "/windows"),
                               number(src, p + "/windows"), number(src, p + "/half_difference_bias"), "–")
        for part, ev in r.get("gyro_evidence", {}).items():
            e = f"{q}/gyro_evidence/{part}"
            for cls in ev["yaw_ratio_by_class"]:
                c = f"{e}/yaw_ratio_by_class/{cls}"
                gyro.add(name, part, class_names.get(cls, cls), number(src, c + "/windows"), number(src, c + "/poses"),
                         number(src, c + "/gyro"))
            if "gyro_lead_median_s" in ev["steps"]:
                lead.add(name, part, number(src, e + "/steps/timed"),
                         *(number(src, f"{e}/steps/gyro_lead_{k}_s") for k in ("q25", "median", "q75")),
                         *((number(src, f"{e}/xcorr/{k}_ahead_s") for k in ("gyro", "poses")) if "xcorr" in ev
                           else ("–", "–")))
        theirs.add(name, number(src, q + "/authors_held_out/end_rms_m"), number(src, q + "/authors_held_out/mean_distance_m"),
                   number(src, q + "/authors_held_out/windows"))
    load = Table("The machine's load during the run.", ["what", "value"])
    add_load(load, src, "/load_before", "/load_after")
    return Page(
        "peers", "Real robots against peers",
        "The field's models of a skid-steer robot on the three shared real logs (Marmotte, tracked; Husky and Warthog, "
        "wheeled): DRIVE, the learned model of Baril et al. (`ICRA 2024`), implemented from its published description "
        "(`mjtrack.models.peers`); the ideal differential drive from the commands and from the measured track speeds; "
        "the ICR kinematic model with a speed scale, fitted on the training windows; and, where the run scored one, "
        "the calibrated MuJoCo robot. Every model is scored on the same held-out windows, the first part of each log "
        "training and the last part testing. DRIVE and the models driven by the commands predict what a planner can "
        "know; those driven by the measured speeds see the drives' response and score the contact alone. The "
        "derivation and what the reproduction shows: the theory page on the peers.",
        [src], [rep, split, models, turns, gyro, lead, regions, speeds, theirs, load])


def _shear_ground() -> Page:
    fid = Source(RESULTS / "shear_fidelity.json")
    sel = Source(RESULTS / "ground_selection.json")
    fidelity = Table("The MuJoCo tracked robot on its surfacevel track model on the shear ground against the shear reference, "
                     "and at K = 1e-4 m against the MuJoCo robot on the Coulomb ground. Errors over half the gauge T/2.",
                     ["check", "cases", "passed", "tolerance / (T/2)", "worst / (T/2)"])
    fidelity.add("against the reference", number(fid, "/summary/cases"), number(fid, "/summary/passed"),
                 number(fid, "/tolerance_over_half_gauge"), number(fid, "/summary/max_err_over_half_gauge"))
    fidelity.add("K -> 0 against the Coulomb robot", number(fid, "/summary/limit_cases"),
                 number(fid, "/summary/limit_passed"), number(fid, "/limit_tolerance_over_half_gauge"),
                 number(fid, "/summary/limit_max_diff_over_half_gauge"))
    tables = [fidelity]
    sources = [fid, sel]
    rollers_path = RESULTS / "shear_fidelity_rollers.json"
    if rollers_path.exists():
        rol = Source(rollers_path)
        sources.append(rol)
        t = Table("The roller chain (tracked robots) and the wheels (two four-wheelers) on the shear ground, the same "
                  "grid: against the shear reference, a wheel also against the reference whose wheel touches at one "
                  "point under its axle as MuJoCo's does (its patch builds the shear, the axle's point slides), and at "
                  "K = 1e-4 m against the same robot on the Coulomb ground. Errors over half the gauge T/2; cases the "
                  "reference has no steady state for are left out and counted.",
                  ["robots", "check", "cases", "passed", "tolerance / (T/2)", "worst / (T/2)"])
        for traction, label in (("tracks", "roller chain"), ("wheels", "wheels")):
            if traction not in rol.data["summary"]:
                continue
            base = f"/summary/{traction}"
            t.add(label, "against the reference", number(rol, base + "/cases"), number(rol, base + "/passed"),
                  number(rol, "/tolerance_over_half_gauge"), number(rol, base + "/max_err_over_half_gauge"))
            if traction == "wheels":
                t.add(label, "the y ICRs against the reference", number(rol, base + "/cases"), "–",
                      number(rol, "/tolerance_over_half_gauge"), number(rol, base + "/max_err_y_over_half_gauge"))
                t.add(label, "against the one-point-contact reference", number(rol, base + "/cases"),
                      number(rol, base + "/passed_point"), number(rol, "/tolerance_over_half_gauge"),
                      number(rol, base + "/max_err_point_over_half_gauge"))
            t.add(label, "K -> 0 against the Coulomb robot", number(rol, base + "/limit_cases"),
                  number(rol, base + "/limit_passed"), number(rol, "/limit_tolerance_over_half_gauge"),
                  number(rol, base + "/limit_max_diff_over_half_gauge"))
        t.add("all", "no steady state of the reference", number(rol, "/summary/no_reference"), "–", "–", "–")
        tables.append(t)
    lateral_path = RESULTS / "shear_fidelity_lateral.json"
    if lateral_path.exists():
        lat = Source(lateral_path)
        sources.append(lat)
        t = Table("Different moduli along and across: the same grid with the shear modulus across the track or tyre "
                  "other than the one along it (`lateral_shear_ratio`, the values in the runs table below; MuJoCo's "
                  "contacts on the track's tangent frames), each case against the reference with that ratio, and at "
                  "a vanishing K (the runs table) against the robot on the Coulomb ground with the same contacts. "
                  "Errors over half the gauge T/2; cases the reference has no steady state for are left out and "
                  "counted.", ["robots", "check", "cases", "passed", "tolerance / (T/2)", "worst / (T/2)"])
        for traction, label in (("tracks", "roller chain"), ("wheels", "wheels")):
            if traction not in lat.data["summary"]:
                continue
            base = f"/summary/{traction}"
            if traction == "wheels":
                t.add(label, "against the one-point-contact reference", number(lat, base + "/cases"),
                      number(lat, base + "/passed_point"), number(lat, "/tolerance_over_half_gauge"),
                      number(lat, base + "/max_err_point_over_half_gauge"))
            else:
                t.add(label, "against the reference", number(lat, base + "/cases"), number(lat, base + "/passed"),
                      number(lat, "/tolerance_over_half_gauge"), number(lat, base + "/max_err_over_half_gauge"))
            t.add(label, "K -> 0 against the Coulomb robot", number(lat, base + "/limit_cases"),
                  number(lat, base + "/limit_passed"), number(lat, "/limit_tolerance_over_half_gauge"),
                  number(lat, base + "/limit_max_diff_over_half_gauge"))
        t.add("all", "no steady state of the reference", number(lat, "/summary/no_reference"), "–", "–", "–")
        worst = Table("The cases of that grid outside the tolerance (the wheels against the one-point-contact "
                      "reference, the roller chain against its reference): where the two part.",
                      ["robot", "v_left [m/s]", "v_right [m/s]", "K [m]", "ratio", "error / (T/2)"])
        for i, c in enumerate(lat.data["cases"]):
            key = "err_point_over_half_gauge" if c["traction"] == "wheels" else "err_over_half_gauge"
            if c[key] > lat.data["tolerance_over_half_gauge"]:
                q = f"/cases/{i}"
                worst.add(c["geometry"], number(lat, q + "/v_left"), number(lat, q + "/v_right"),
                          number(lat, q + "/shear_modulus"), number(lat, q + "/lateral_shear_ratio"), number(lat, q + "/" + key))
        tables += [t, worst]
    runs = Table("The runs: seconds and the machine's one-minute load average before and after.", ["run", "value"])
    runs.add("fidelity grid: seconds", number(fid, "/elapsed_s"))
    runs.add("fidelity grid: load before", number(fid, "/load_before/0"))
    runs.add("fidelity grid: load after", number(fid, "/load_after/0"))
    if rollers_path.exists():
        runs.add("roller-chain and wheels grid: seconds", number(rol, "/elapsed_s"))
        runs.add("roller-chain and wheels grid: load before", number(rol, "/load_before/0"))
        runs.add("roller-chain and wheels grid: load after", number(rol, "/load_after/0"))
    if lateral_path.exists():
        for i in range(len(lat.data["lateral_shear_ratios"])):
            runs.add("grid with moduli along and across: a ratio", number(lat, f"/lateral_shear_ratios/{i}"))
        runs.add("grid with moduli along and across: the vanishing K [m]", number(lat, "/limit/0/shear_modulus"))
        runs.add("grid with moduli along and across: seconds", number(lat, "/elapsed_s"))
        runs.add("grid with moduli along and across: load before", number(lat, "/load_before/0"))
        runs.add("grid with moduli along and across: load after", number(lat, "/load_after/0"))
    classes = sel.data["robots"][next(iter(sel.data["robots"]))]["turn_classes"]
    header = ["robot", "ground", "K [m]", "f_r", "length factor", "on a bound", "held-out class gap (RMS)"]
    for lo, hi in classes:
        header += [f"|turn ratio| {lo:g} to {hi:g}: {what}" for what in ("predicted", "measured", "windows")]
    selection = Table("Steady yaw ratio per turn class (all windows), measured on the shared logs and predicted by "
                      "each ground's reference, its parameters fitted on the first part of the log; the held-out "
                      "gap is on the rest.", header)
    chosen = Table("The ground each robot selects: among the candidates with no parameter on a bound, the one with "
                   "the fewest parameters whose held-out class gap is within one bootstrap standard error of the "
                   "lowest.", ["robot", "selected", "lowest held-out gap", "its standard error", "windows", "seconds"])
    for robot, r in sel.data["robots"].items():
        for cand, c in r["candidates"].items():
            p = f"/robots/{robot}/candidates/{cand}"
            cells = [robot, cand, number(sel, p + "/shear_modulus"), number(sel, p + "/rolling_resistance"),
                     number(sel, p + "/length_factor"),
                     number(sel, p + "/on_bound"), number(sel, p + "/test/rms_gap")]
            for i, k in enumerate(c["all"]["classes"]):
                q = f"{p}/all/classes/{i}"
                cells += ["–"] * 3 if k is None else [number(sel, q + f"/{f}") for f in ("predicted", "measured", "windows")]
            selection.add(*cells)
        chosen.add(robot, r["selected"] or "none", number(sel, f"/robots/{robot}/selection/lowest_gap"),
                   number(sel, f"/robots/{robot}/selection/standard_error"), number(sel, f"/robots/{robot}/windows"),
                   number(sel, f"/robots/{robot}/seconds"))
    runs.add("ground selection, last run: load before", number(sel, "/load_before/0"))
    runs.add("ground selection, last run: load after", number(sel, "/load_after/0"))
    scan_path = RESULTS / "shear_scan.json"
    extra = []
    if scan_path.exists():
        scan = Source(scan_path)
        sources.append(scan)
        class_names = _turn_class_names()
        scan_t = Table("The MuJoCo robot on the shear ground alone, nothing fitted to the poses (`python "
                       "benchmarks/real_robots.py --shear-scan`, its docstring): the public starting robot on the "
                       "shear ground of each modulus K (0: Coulomb), its drives fitted to the measured track speeds "
                       "as calibrate fits them first, scored on the test part of the reference split: the held-out "
                       "2 s position error, and per turn class of the test part's steady turns the yaw ratio and "
                       "the forward speed ratio, measured / simulated (the classes of the calibration page: "
                       "straight, turning, sharp turns by |turn ratio|).",
                       ["robot", "K [m]", "held-out error [m]", "class", "windows", "measured", "simulated"])
        for robot, r in scan.data["robots"].items():
            for key, m in r["moduli"].items():
                p = f"/robots/{robot}/moduli/{key}"
                for what in m["classes"]:
                    q = f"{p}/classes/{pointer_token(what)}"
                    quantity, _, cls = what.partition(" (")
                    scan_t.add(robot, number(scan, p + "/shear_modulus"), number(scan, p + "/test_error"),
                               f"{quantity}, {class_names.get('(' + cls, cls)}",
                               number(scan, q + "/windows"), number(scan, q + "/measured"),
                               number(scan, q + "/simulated"))
        runs.add("shear scan: load before", number(scan, "/load_before/0"))
        runs.add("shear scan: load after", number(scan, "/load_after/0"))
        extra = [scan_t]
    return Page(
        "shear_ground", "The shear-displacement ground",
        "The Janosi-Hanamoto shear ground (theory: the shear-displacement ground page): the MuJoCo robot against "
        "its reference and its Coulomb limit, and which ground the three real robots' steady turns select.",
        sources, tables + [selection, chosen] + extra + [runs])


PAGES: tuple[Callable[[], Page], ...] = (_fidelity, _diagnosis, _implementations, _filters, _speed, _wheeled,
                                          _wheeled_models, _controllers, _calibration, _peers, _shear_ground)


# -- writing -----------------------------------------------------------------------------------
def _escape(text: str) -> str:
    return text.replace("|", "\\|")


def render(page: Page) -> tuple[str, list[dict]]:
    """The page's Markdown and the provenance of its numbers (table, row, column: 0-based)."""
    lines = [f"# {page.title}", "", page.intro, ""]
    provenance = []
    for t_index, table in enumerate(page.tables):
        lines += [f"**{_escape(table.caption)}**", "", "| " + " | ".join(map(_escape, table.header)) + " |",
                  "|" + "---|" * len(table.header)]
        for r_index, row in enumerate(table.rows):
            lines.append("| " + " | ".join(_escape(c.text) for c in row) + " |")
            for c_index, cell in enumerate(row):
                if cell.provenance is not None:
                    provenance.append({"table": t_index, "row": r_index, "column": c_index, "text": cell.text,
                                       **cell.provenance})
        lines.append("")
    for path, caption in page.figures:
        lines += [f"```{{figure}} {path.name}", "", caption, "```", ""]
    lines += ["**Result files**", ""]
    for src in page.sources:
        made = f", written by `{src.command}`" if src.command else ""
        lines.append(f"- `{src.rel}`{made}")
    lines += [f"- `{fig.relative_to(ROOT).as_posix()}` (the figure)" for fig, _ in page.figures]
    lines.append("")
    if page.written:
        lines += ["**Written beside them** (the calibrated robots and their reports)", ""]
        lines += [f"- `{p.relative_to(ROOT).as_posix()}`" for p in page.written]
        lines.append("")
    return "\n".join(lines), provenance


def write_pages(out: Path = DEFAULT_OUT) -> list[Path]:
    """Write every results page, its figures and ``_provenance.json`` into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("*.md"):  # a page no longer generated must not linger in the build
        old.unlink()
    provenance: dict[str, list[dict]] = {}
    written = []
    index = ["# Results", "",
             "Every table and figure here is generated from the result files the benchmark scripts write "
             "(`python docs/_ext/results_pages.py`, run by `docs/build`); each page names its result files and "
             "the commands that wrote them.", "", "```{toctree}", ":maxdepth: 1", ""]
    missing = []
    for make in PAGES:
        try:
            page = make()
        except FileNotFoundError as e:  # a benchmark not run yet in this checkout: its page is left out, said below
            missing.append(Path(e.filename).relative_to(ROOT).as_posix() if e.filename else str(e))
            continue
        text, prov = render(page)
        path = out / f"{page.name}.md"
        path.write_text(text)
        for fig, _ in page.figures:
            shutil.copyfile(fig, out / fig.name)
        provenance[page.name] = prov
        index.append(page.name)
        written.append(path)
    index += ["```", ""]
    if missing:
        index += ["Pages left out: their result files are not in this checkout (run the benchmark that writes "
                  "them): " + ", ".join(f"`{m}`" for m in missing) + ".", ""]
    (out / "index.md").write_text("\n".join(index))
    (out / "_provenance.json").write_text(json.dumps(provenance, indent=1) + "\n")
    return written


def _on_builder_inited(app) -> None:
    write_pages(Path(app.srcdir) / "results")


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True}


if __name__ == "__main__":
    for p in write_pages(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_OUT):
        print(p)
