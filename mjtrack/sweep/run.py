"""Steady-state sweeps on a dask cluster: cases out, rows back, written as they finish.

:func:`run_sweep` splits a :class:`~mjtrack.sweep.grid.Grid`'s cases into chunks, runs each
chunk on a ``dask.distributed`` worker through :func:`mjtrack.sim.steady.steady_batch` (one
``mujoco.rollout`` call over the chunk's models; each case still runs from its own settled
state, so a case's numbers do not depend on the chunk it is in nor on the worker count), and
appends each finished case to ``DIR/sweep.partial.csv`` at once (flushed), in completion order;
``DIR/sweep.partial.json`` holds the settings the rows were made with.

Resume: when ``DIR/sweep.partial.csv`` exists, its complete rows whose case index and grid values
match the grid are kept and only the other cases run (a row cut short by a kill is dropped);
under other settings it is refused, or discarded with ``restart``.
At the end the outputs are written sorted by case (atomically), so the finished ``sweep.csv`` has
the same bytes whatever the worker count and the completion order, with ``sweep.json`` and
``icr_map.png``; then the two partial files are removed. The folder therefore holds either the
complete set or only what a resume needs (an interrupt during that last step takes effect after
it: :func:`mjtrack.interrupts.deferred`).

Columns: ``case``, the grid keys, ``v_left_cmd``, ``v_right_cmd`` (unless grid keys), then
the steady-state result as :meth:`SteadyResult.to_dict` gives it (``v_left``, ``v_right``,
``vx``, ``vy``, ``wz``, ..., ``y_l``, ``y_r``, ``x_c``, ...). Floats are written with
``repr`` (exact); an undefined value (an ICR when the robot does not turn) is an empty cell
in the CSV and ``null`` in the JSON.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

from mjtrack import interrupts
from mjtrack.errors import InputError, MjtrackError
from mjtrack.io import atomic
from mjtrack.io.atomic import atomic_write_bytes, atomic_write_text
from mjtrack.progress import Progress
from mjtrack.resources import available_memory
from mjtrack.sim.config import sim_config
from mjtrack.sim.steady import SETTLE_S, WINDOW_S, SteadyResult, check_steady, steady_batch
from mjtrack.sim.terrain import Terrain
from mjtrack.sweep.grid import Case, Grid

logger = logging.getLogger(__name__)

CSV_NAME, JSON_NAME, MAP_NAME = "sweep.csv", "sweep.json", "icr_map.png"
PARTIAL_CSV, PARTIAL_JSON = "sweep.partial.csv", "sweep.partial.json"  # the resume state
OUTPUTS = (CSV_NAME, JSON_NAME, MAP_NAME)
RESULT_KEYS: tuple[str, ...] = tuple(SteadyResult.__dataclass_fields__)
CONNECT_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep did: cases in the grid, cases run now, cases kept from an earlier run."""

    cases: int
    ran: int
    resumed: int
    seconds: float  # [s] the whole call
    run_seconds: float  # [s] from the first case submitted to the last result (no start-up, no figure)
    workers: int


def header(grid: Grid) -> list[str]:
    cols = ["case", *grid.keys]
    cols += [k for k in RESULT_KEYS if k not in cols]
    return cols


def run_chunk(cases: Sequence[Case], track_model: str, settle_s: float, window_s: float,
              terrain: Terrain | None = None) -> list[tuple[int, dict[str, Any]]]:
    """Steady states of a chunk of cases (runs on a worker): [(case index, result dict)]."""
    results = steady_batch([c.robot for c in cases], [[c.v_left_cmd, c.v_right_cmd] for c in cases],
                           config=sim_config(track_model), settle_s=settle_s, window_s=window_s, nthread=1,
                           terrain=terrain)
    return [(c.index, r.to_dict()) for c, r in zip(cases, results)]


def _cell(value: Any) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _row(case: Case, result: dict[str, Any], cols: list[str]) -> list[str]:
    values = {"case": case.index, **dict(case.values), **result}
    return [_cell(values.get(c)) for c in cols]


def _read_done(path: Path, grid: Grid, cols: list[str]) -> dict[int, list[str]]:
    """Complete rows of an earlier run of the same grid: {case index: cells}."""
    if not path.exists():
        return {}
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the earlier sweep to resume it ({exc})") from None
    lines = text.split("\n")
    complete = lines[:-1]  # the part after the last newline is empty or a row cut short
    if not complete:
        return {}
    rows = list(csv.reader(complete))
    if rows[0] != cols:
        raise InputError(f"{path}: written by a sweep with other columns ({','.join(rows[0])[:80]}...); "
                         f"{_START_OVER}")
    done: dict[int, list[str]] = {}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(cols):
            continue
        try:
            k = int(row[0])
        except ValueError:
            continue
        if not 0 <= k < len(grid.cases):
            continue
        case = grid.cases[k]
        if row[1:1 + len(case.values)] != [_cell(v) for _, v in case.values]:
            raise InputError(f"{path}: line {line}: case {k} was run with other grid values; {_START_OVER}")
        done[k] = row
    return done


_START_OVER = "use another out=DIR, delete the file or pass restart=True to start over"
MAX_CHUNK = 16  # cases per task at most: a finished chunk is written (and kept on resume) at once


def auto_chunk_size(n_cases: int, slots: int) -> int:
    """Cases per task: two tasks per worker thread, at most :data:`MAX_CHUNK` cases.

    A task costs the scheduler round trip (about 10 ms here) beside its cases (about 60 ms each
    for the default 5 s steady state), so small chunks waste time on a small grid, while fewer
    than two tasks per thread leaves a thread idle when case costs differ. Measured on the
    24-case benchmark, 2 workers (benchmarks/bench_sweep.py): 4 per chunk 0.82 s, 6 per chunk
    0.81 s, 1 per chunk 0.89 s; results do not depend on it.
    """
    return max(1, min(MAX_CHUNK, math.ceil(n_cases / (2 * max(1, slots)))))


def _chunks(cases: Sequence[Case], size: int) -> Iterator[list[Case]]:
    """ceil(n / size) chunks of at most ``size`` cases, dealt out in turn (case i to chunk
    i mod n_chunks): neighbours in a grid share a speed, and fast cases cost more steps on the
    roller chain (SimConfig.lag_budget), so consecutive chunks would differ in cost."""
    n = math.ceil(len(cases) / size) if cases else 0
    for j in range(n):
        yield list(cases[j::n])


@contextlib.contextmanager
def _client(workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """A dask client: on ``scheduler`` (an existing cluster) or on a new local cluster of
    ``workers`` processes with one thread each."""
    from dask.distributed import Client, LocalCluster

    if not logger.isEnabledFor(logging.DEBUG):  # dask logs its start-up at INFO; keep the CLI quiet
        logging.getLogger("distributed").setLevel(logging.ERROR)
    if scheduler:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"scheduler={scheduler!r}: cannot reach a dask scheduler ({exc})") from None
        with client:
            yield client
        return
    with interrupts.silent_children():  # a Ctrl-C kills the workers too: without a traceback each
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        yield client


WORKER_MEMORY = 300e6  # [bytes] a local dask worker process with MuJoCo loaded, running a chunk (measured ~250 MB)


MAX_WORKERS_PER_CORE = 4  # more local worker processes than this per core only add start-up time and memory


def check_worker_memory(workers: int) -> None:
    """Refuse a local cluster of more than :data:`MAX_WORKERS_PER_CORE` processes per core, or one
    whose worker processes would not fit in the memory available now (with the estimate)."""
    cores = os.cpu_count() or 1
    if workers > MAX_WORKERS_PER_CORE * cores:
        raise InputError(f"workers={workers}: more than {MAX_WORKERS_PER_CORE} worker processes per core "
                         f"({cores} cores here); use at most {MAX_WORKERS_PER_CORE * cores}")
    available = available_memory()
    need = workers * WORKER_MEMORY
    if available is not None and need > available:
        raise InputError(f"workers={workers}: {workers} worker processes need about {need / 1e9:.1f} GB "
                         f"({WORKER_MEMORY / 1e6:.0f} MB each), {available / 1e9:.1f} GB are available; "
                         f"use at most {max(1, int(available // WORKER_MEMORY))}")


def run_sweep(
    grid: Grid,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    track_model: str = "rollers",
    settle_s: float = SETTLE_S,
    window_s: float = WINDOW_S,
    chunk_size: int | None = None,
    terrain: Terrain | None = None,
    quiet: bool = False,
    restart: bool = False,
) -> SweepSummary:
    """Run every case of ``grid`` not already in ``out/sweep.partial.csv``; write the outputs.

    ``workers``: processes of a new local cluster (default: the CPU count); ``scheduler``: the
    address of an existing dask scheduler instead. ``chunk_size`` cases share one batched
    rollout on a worker (results do not depend on it); default :func:`auto_chunk_size`. ``terrain``: the ground of every case
    (default flat). ``restart``: discard a partial sweep that cannot be resumed (other settings,
    grid or columns) instead of refusing it.
    """
    from dask.distributed import as_completed

    out = Path(out)
    sim_config(track_model)  # refuses an unknown model before any work
    if workers is not None and workers < 1:
        raise InputError(f"workers: must be >= 1, got {workers}")
    if workers is not None and scheduler is None:
        check_worker_memory(workers)
    check_steady([c.robot for c in grid.cases], [[c.v_left_cmd, c.v_right_cmd] for c in grid.cases],
                 config=sim_config(track_model), settle_s=settle_s, window_s=window_s, terrain=terrain,
                 batch=min(chunk_size or MAX_CHUNK, len(grid.cases)))
    cols = header(grid)
    csv_path, json_path = out / PARTIAL_CSV, out / PARTIAL_JSON
    settings = {"grid": grid.to_dict(), "track_model": track_model, "settle_s": settle_s, "window_s": window_s,
                "base_robot": _base_robot(grid)}
    if terrain is not None and not terrain.is_flat:  # absent when flat: sweeps started before --terrain resume
        settings["terrain"] = terrain.to_dict()
    # every simulator setting (time-step rules, belt, principal axes, ...): a sweep started under
    # other settings (older sweep files kept only ``lag_budget``, or no setting at all) is
    # refused instead of mixing two models' rows in one file
    settings["sim_config"] = sim_config(track_model).to_dict()
    try:
        _check_same_settings(json_path, csv_path, settings)
        done = _read_done(csv_path, grid, cols)
    except InputError:
        if not restart:
            raise
        logger.warning("%s: an earlier sweep that cannot be resumed; starting over (--force)", csv_path)
        done = {}
    todo = [c for c in grid.cases if c.index not in done]
    start = time.monotonic()
    tx = atomic.current()
    for p in (csv_path, json_path):  # the resume state: rewritten freely, kept when the run is cut short
        if tx is not None:
            tx.allow(p)
            tx.keep(p)
    n_workers, run_seconds = 0, 0.0
    if todo:
        with _client(workers or os.cpu_count() or 1, scheduler) as client:  # a refused cluster writes nothing
            workers_info = client.scheduler_info().get("workers", {})
            n_workers = len(workers_info)
            slots = sum(int(w.get("nthreads", 1)) for w in workers_info.values()) or 1
            size = chunk_size or auto_chunk_size(len(todo), slots)
            atomic.make_output_dir(out)
            _write_json(json_path, grid, settings, cols, [])  # the settings first: a resume checks them
            # write the kept rows back without any partial tail, then append as cases finish
            atomic_write_text(csv_path, _csv_text(cols, [done[k] for k in sorted(done)]))
            t_submit = time.monotonic()
            futures = [client.submit(run_chunk, chunk, track_model, settle_s, window_s, terrain, pure=False)
                       for chunk in _chunks(todo, size)]
            with open(csv_path, "a", encoding="utf-8", newline="") as fh, \
                    Progress(len(todo), label="sweep", quiet=quiet) as bar:
                writer = csv.writer(fh, lineterminator="\n")
                for fut in as_completed(futures):
                    try:
                        rows = fut.result()
                    except MjtrackError:
                        raise
                    except Exception as exc:  # a worker lost, a pickling problem: one line, exit 1
                        raise MjtrackError(f"sweep worker failed: {type(exc).__name__}: {exc}") from None
                    for k, result in rows:
                        row = _row(grid.cases[k], result, cols)
                        writer.writerow(row)
                        done[k] = row
                    fh.flush()
                    bar.update(len(rows))
            run_seconds = time.monotonic() - t_submit
    records = [_record(cols, done[k]) for k in sorted(done)]
    from mjtrack.sweep.figure import icr_map_png

    png = icr_map_png(records, grid)
    with interrupts.deferred():  # the complete set, then the resume state goes
        atomic_write_text(out / CSV_NAME, _csv_text(cols, [done[k] for k in sorted(done)]))
        _write_json(out / JSON_NAME, grid, settings, cols, records)
        atomic_write_bytes(out / MAP_NAME, png)
        for p in (csv_path, json_path):
            if tx is not None:
                tx.discard(p)
            p.unlink(missing_ok=True)
        if tx is not None:
            tx.commit()
    return SweepSummary(cases=len(grid.cases), ran=len(todo), resumed=len(grid.cases) - len(todo),
                        seconds=time.monotonic() - start, run_seconds=run_seconds, workers=n_workers)


def _write_json(path: Path, grid: Grid, settings: dict[str, Any], cols: list[str], records: list) -> None:
    atomic_write_text(path, json.dumps({**settings, "grid_file": grid.source, "columns": cols, "cases": records},
                                       indent=1) + "\n")


def _check_same_settings(json_path: Path, csv_path: Path, settings: dict[str, Any]) -> None:
    """A partial sweep is resumed only under the settings it was started with (kept beside it)."""
    if not csv_path.exists():
        return
    try:
        old = json.loads(json_path.read_text(encoding="utf-8"))
        keys = [*settings, *(["terrain"] if "terrain" not in settings else [])]  # flat: no key
        same = all(old.get(k) == json.loads(json.dumps(settings.get(k))) for k in keys)
    except (OSError, ValueError, AttributeError):
        raise InputError(f"{csv_path}: an earlier sweep without a readable {json_path.name}: cannot tell how it "
                         f"was run; {_START_OVER}") from None
    if not same:
        changed = [k for k in keys if old.get(k) != json.loads(json.dumps(settings.get(k)))]
        raise InputError(f"{csv_path}: an earlier sweep with other settings ({', '.join(changed)}); {_START_OVER}")


def _base_robot(grid: Grid) -> dict[str, Any]:
    robot = grid.cases[0].robot.to_dict()
    return {k: v for k, v in robot.items() if k not in grid.keys}


def _csv_text(cols: list[str], rows: list[list[str]]) -> str:
    import io

    buf = io.StringIO(newline="")
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(cols)
    writer.writerows(rows)
    return buf.getvalue()


def _record(cols: list[str], row: list[str]) -> dict[str, Any]:
    """A CSV row back as JSON values: numbers, null for empty cells, text otherwise."""
    rec: dict[str, Any] = {}
    for c, cell in zip(cols, row):
        if cell == "":
            rec[c] = None
            continue
        try:
            rec[c] = int(cell) if c == "case" else float(cell)
        except ValueError:
            rec[c] = cell
    return rec
