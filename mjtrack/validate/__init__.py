"""Model-vs-physics validation: every kinematic model and filter against a MuJoCo log and MPP truth."""

from mjtrack.validate.evaluate import HORIZONS as HORIZONS
from mjtrack.validate.evaluate import CaseResult as CaseResult
from mjtrack.validate.evaluate import evaluate_case as evaluate_case
from mjtrack.validate.horizon import dead_reckoning as dead_reckoning
from mjtrack.validate.horizon import horizon_errors_per_start as horizon_errors_per_start
from mjtrack.validate.predictors import Predictor as Predictor
from mjtrack.validate.predictors import build_predictors as build_predictors
from mjtrack.validate.predictors import fit_icr_windows as fit_icr_windows
from mjtrack.validate.predictors import fit_mpp_windows as fit_mpp_windows
from mjtrack.validate.predictors import run_filters as run_filters
from mjtrack.validate.run import Validation as Validation
from mjtrack.validate.run import validate as validate
from mjtrack.validate.truth import MPP_TRUTH as MPP_TRUTH
from mjtrack.validate.truth import Case as Case
from mjtrack.validate.truth import Noise as Noise
from mjtrack.validate.truth import case_from_log as case_from_log
from mjtrack.validate.truth import mpp_case as mpp_case
