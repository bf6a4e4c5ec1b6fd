"""Sweeps: many runs of any run configuration, local or on a Ray cluster, resumable.

``spec = load_sweep("noise")``; ``run_sweep(spec, "out/noise", executor="local")``;
``status(dir)``; ``write_report(dir)``. Files: docs/sweep.md.
"""

from simcalib.sweep.report import write_report
from simcalib.sweep.runner import SweepSummary, run_sweep
from simcalib.sweep.store import status
from simcalib.sweep.spec import Cell, SweepSpec, expand, list_sweeps, load_sweep

__all__ = ["Cell", "SweepSpec", "SweepSummary", "expand", "list_sweeps", "load_sweep",
           "run_sweep", "status", "write_report"]
