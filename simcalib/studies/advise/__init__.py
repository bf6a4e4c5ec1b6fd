"""Motion advice: which motions to record next so that X becomes best determined, within
what the platform can do, verified in simulation (docs/advice.md)."""

from simcalib.studies.advise.advisor import (Advice, Baseline, Verification, advice_dict, advise,
                                     advise_motions, baseline, solve_errors, verify)
from simcalib.studies.advise.feasibility import Candidates, candidates, execute_stops, stop_motions
from simcalib.studies.advise.planner import greedy, motion_information, predicted_std, undeterminable
from simcalib.studies.advise.recorded import RecordedAdvice, advise_recorded, recorded_advice_dict

__all__ = ["Advice", "Baseline", "Verification", "advice_dict", "advise", "advise_motions",
           "baseline", "solve_errors", "verify", "Candidates", "candidates", "execute_stops",
           "stop_motions", "greedy", "motion_information", "predicted_std", "undeterminable",
           "RecordedAdvice", "advise_recorded", "recorded_advice_dict"]
