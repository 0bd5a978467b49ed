"""Diagnosis: what a baseline model gets wrong on a measured log, the cause, and its gain.

One pipeline for every baseline (:class:`Baseline`: the Coulomb surrogate and the kinematic
model, :mod:`.surrogate`; the MuJoCo robot, :mod:`.mujoco_baseline`, imported only when a
diagnosis simulates): symptoms (:mod:`.residuals`) -> candidate effects of one vocabulary
(:mod:`.vocabulary`) as extensions of the baseline, on one data-only :class:`Problem`
(:mod:`.problem`) -> fits (:meth:`Baseline.fit`) -> cross-validated ranking with a "none"
decision, ties and forward selection (:mod:`.select`, statistics in :mod:`.stats`, physical ties
in :mod:`.ties`) -> one result (:class:`Diagnosis`, :mod:`.result`) -> diagnosis.json and
report.html (:func:`write_outputs`, :mod:`.report`); optional MuJoCo confirmation of a
surrogate's cause (:mod:`.confirm`).
"""

from mjtrack.diagnose.baseline import Baseline as Baseline
from mjtrack.diagnose.baseline import ModelForm as ModelForm
from mjtrack.diagnose.confirm import confirm as confirm
from mjtrack.diagnose.problem import Problem as Problem
from mjtrack.diagnose.result import Diagnosis as Diagnosis
from mjtrack.diagnose.result import extended_robot as extended_robot
from mjtrack.diagnose.run import diagnose as diagnose
from mjtrack.diagnose.run import write_outputs as write_outputs
from mjtrack.diagnose.surrogate import Surrogate as Surrogate
from mjtrack.diagnose.surrogate import SurrogateBaseline as SurrogateBaseline
from mjtrack.diagnose.vocabulary import EFFECTS as EFFECTS
from mjtrack.diagnose.vocabulary import Effect as Effect

__all__ = ["Baseline", "Diagnosis", "EFFECTS", "Effect", "ModelForm", "Problem", "Surrogate", "SurrogateBaseline",
           "confirm", "diagnose", "extended_robot", "write_outputs"]
