"""Diagnosis (issue 6): what the nominal model gets wrong on a measured log, the cause, and its gain.

Symptoms (:mod:`.residuals`) -> candidate effects as surrogate extensions (:mod:`.effects`,
:mod:`.surrogate`) -> least-squares fits (:mod:`.fit`) -> cross-validated ranking with a "none"
decision (:mod:`.select`) -> diagnosis.json and report.html (:mod:`.run`, :mod:`.report`); optional
MuJoCo confirmation of the cause (:mod:`.confirm`).
"""

from mjtrack.diagnose.effects import EFFECTS as EFFECTS
from mjtrack.diagnose.effects import Effect as Effect
from mjtrack.diagnose.effects import Surrogate as Surrogate
from mjtrack.diagnose.result import Diagnosis as Diagnosis
from mjtrack.diagnose.run import diagnose as diagnose
from mjtrack.diagnose.result import extended_robot as extended_robot
from mjtrack.diagnose.run import write_outputs as write_outputs
from mjtrack.diagnose.confirm import confirm as confirm
