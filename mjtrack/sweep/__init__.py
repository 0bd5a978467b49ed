"""Steady-state sweeps over grids of commands and robots, on a dask cluster (``mjtrack sweep``).

``grid`` reads and expands GRID.json into cases; ``run`` runs them on ``dask.distributed``
workers (batched ``mujoco.rollout`` per chunk), writes rows as they finish and resumes;
``figure`` draws the ICR map.
"""

from mjtrack.sweep.grid import Case as Case
from mjtrack.sweep.grid import Grid as Grid
from mjtrack.sweep.grid import grid_from_dict as grid_from_dict
from mjtrack.sweep.grid import read_grid as read_grid
from mjtrack.sweep.grid import track_commands as track_commands
from mjtrack.sweep.run import SweepSummary as SweepSummary
from mjtrack.sweep.run import run_sweep as run_sweep

__all__ = ["Case", "Grid", "SweepSummary", "grid_from_dict", "read_grid", "run_sweep", "track_commands"]
