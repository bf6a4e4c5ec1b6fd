"""Sweeps: many runs of any run configuration, local or on a Ray cluster, resumable.

``spec = load_sweep("noise")``; ``run_sweep(spec, "out/noise", executor="local")``;
``status(dir)``; ``write_report(dir)``. Files: docs/sweep.md.
"""

from simcalib.studies.sweep.report import write_report
from simcalib.studies.sweep.runner import SweepSummary, run_sweep
from simcalib.studies.sweep.store import status
from simcalib.studies.sweep.spec import Cell, SweepSpec, expand, list_sweeps, load_sweep

__all__ = ["Cell", "SweepSpec", "SweepSummary", "expand", "list_sweeps", "load_sweep",
           "run_sweep", "status", "write_report"]
