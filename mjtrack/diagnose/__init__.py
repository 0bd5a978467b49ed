"""Diagnosis: what a baseline model gets wrong on a measured log, the cause, and its gain.

One pipeline for every baseline (:class:`mjtrack.diagnose.baseline.Baseline`: the Coulomb
surrogate and the kinematic model, :mod:`.surrogate_baseline`; the MuJoCo robot,
:mod:`.mujoco_baseline`): symptoms (:mod:`.residuals`) -> candidate effects of one vocabulary
(:mod:`.effects`) as extensions of the baseline -> fits (:meth:`Baseline.fit`) -> cross-validated
ranking with a "none" decision, ties and forward selection (:mod:`.select`) -> one result
(:class:`Diagnosis`, :mod:`.result`) -> diagnosis.json and report.html (:func:`write_outputs`,
:mod:`.report`); optional MuJoCo confirmation of a surrogate's cause (:mod:`.confirm`).
"""

from mjtrack.diagnose.baseline import Baseline as Baseline
from mjtrack.diagnose.baseline import ModelForm as ModelForm
from mjtrack.diagnose.effects import EFFECTS as EFFECTS
from mjtrack.diagnose.effects import Effect as Effect
from mjtrack.diagnose.effects import Surrogate as Surrogate
from mjtrack.diagnose.result import Diagnosis as Diagnosis
from mjtrack.diagnose.run import diagnose as diagnose
from mjtrack.diagnose.result import extended_robot as extended_robot
from mjtrack.diagnose.run import write_outputs as write_outputs
from mjtrack.diagnose.confirm import confirm as confirm
