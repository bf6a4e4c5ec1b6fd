"""Motion advice: which motions to record next so that X becomes best determined, within
what the platform can do, verified in simulation (docs/advice.md).

Modules, lowest first: ``information`` (what motions tell about X), ``planner`` (the
choice of a stop-and-go chain), ``feasibility`` (candidate stops a platform can make),
``stops`` (measuring stops in the simulator), ``systematic`` (the shared pose errors),
``advisor`` (advice for a scenario's recorded run), ``outcomes`` (errors of a set of
stops), ``bounds`` (hindsight bound, model floor), ``verification``, ``advice_json``,
``console`` (what the command prints), ``recorded`` (advice for pose files), ``tables``
(docs/advice.md)."""

from simcalib.studies.advise.advice_json import advice_dict
from simcalib.studies.advise.advisor import Advice, Baseline, advise, advise_motions, baseline
from simcalib.studies.advise.feasibility import Candidates, candidates
from simcalib.studies.advise.information import (motion_information, predicted_std,
                                                 undeterminable)
from simcalib.studies.advise.outcomes import solve_errors
from simcalib.studies.advise.planner import greedy
from simcalib.studies.advise.recorded import (RecordedAdvice, advise_recorded,
                                              recorded_advice_dict)
from simcalib.studies.advise.stops import execute_stops, stop_motions
from simcalib.studies.advise.verification import Verification, verify

__all__ = ["Advice", "Baseline", "Verification", "advice_dict", "advise", "advise_motions",
           "baseline", "solve_errors", "verify", "Candidates", "candidates", "execute_stops",
           "stop_motions", "greedy", "motion_information", "predicted_std", "undeterminable",
           "RecordedAdvice", "advise_recorded", "recorded_advice_dict"]
