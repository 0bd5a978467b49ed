"""Parameter estimation for the kinematic models: slip, ICR and virtual-robot filters.

Models and filters of the tracked-robot thesis (Mendaluk 2019; docs/theory/tracked.md).
"""

from mjtrack.estimation.common import FilterInputs as FilterInputs
from mjtrack.estimation.common import FilterResult as FilterResult
from mjtrack.estimation.common import chi2_band as chi2_band
from mjtrack.estimation.common import inputs_from_log as inputs_from_log
from mjtrack.estimation.common import residual as residual
from mjtrack.estimation.common import twist_from_poses as twist_from_poses
from mjtrack.estimation.icr_ekf import InverseICR as InverseICR
from mjtrack.estimation.icr_ekf import icr_from_psi as icr_from_psi
from mjtrack.estimation.icr_ekf import icr_from_thesis_params as icr_from_thesis_params
from mjtrack.estimation.icr_ekf import run_icr_ekf as run_icr_ekf
from mjtrack.estimation.icr_ekf import run_icr_ekf_thesis as run_icr_ekf_thesis
from mjtrack.estimation.pose_ekf import run_pose_param_ekf as run_pose_param_ekf
from mjtrack.estimation.slip_ekf import run_slip_ekf as run_slip_ekf
from mjtrack.estimation.vir_filter import centre_from_thesis_state as centre_from_thesis_state
from mjtrack.estimation.vir_filter import run_vir_filter as run_vir_filter
from mjtrack.estimation.vir_filter import run_vir_thesis as run_vir_thesis
from mjtrack.estimation.vir_filter import sphere_from_psi as sphere_from_psi
from mjtrack.estimation.vir_filter import virtual_from_psi as virtual_from_psi
