"""The kinds of generated recording (:data:`KINDS`: stations, short, bursts, stop-and-go,
continuous, a low-rate camera, offsets and drift, outliers, gaps, robot error, planar,
SCARA, pure and nearly pure translation, inverted, scalar-first, stamps in ms / us / ns, b
in another scale, no motion) and :func:`generate` (a kind and a seed -> a
:class:`Recording`), the true streams, and the TUM files a recording is written as
(``a.txt``, ``b.txt``, ``truth.json``).

The parts: ``stations`` (an arm that stops), ``continuous`` (one smooth motion streamed),
``readings`` (files to be read another way), ``error_model`` (the robot's and the
camera's systematic errors), ``catalogue`` (:data:`KINDS`), ``generation``
(:func:`generate`, :func:`true_streams`); the building blocks (rig, clocks, motions) are
:mod:`~simcalib.studies.experiments.recording_models`.
"""

from simcalib.studies.experiments.recording_files import read_truth, write_tum
from simcalib.studies.experiments.recording_kinds.catalogue import KINDS
from simcalib.studies.experiments.recording_kinds.error_model import (WORKSPACE_STATIONS,
                                                                      workspace_X)
from simcalib.studies.experiments.recording_kinds.generation import generate, true_streams
from simcalib.studies.experiments.recording_kinds.readings import UNIX_EPOCH_S

__all__ = ["KINDS", "generate", "true_streams", "write_tum", "read_truth", "workspace_X"]
