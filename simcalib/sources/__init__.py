"""Pose sources: one file per source, a registry, and the ground truth they measure.

    from simcalib.sources import available_sources, get_source
    out = get_source("noisy", "sim").measure(truth, cfg, rng, ("cam_a", "cam_b"))

The sources are whatever files of this folder registered themselves
(``available_sources()``, ``python -m simcalib list``). See :mod:`simcalib.sources.base` for
the protocol and docs/extending.md for how to add one.
"""

from simcalib.sources.base import CAMERAS, GroundTruth, PoseSource, SourceInfo, SourceOutput
from simcalib.sources.registry import (SOURCES, available_sources, camera_sources,
                                       get_source, register, sources_for_kind)
# the source files register themselves when the first lookup imports every module of this
# folder (SOURCES.load(); each file is light: heavy imports happen inside measure())
from simcalib.sources.truth import KINDS, build_truth

__all__ = ["CAMERAS", "SOURCES", "GroundTruth", "PoseSource", "SourceInfo", "SourceOutput", "KINDS",
           "available_sources", "build_truth", "camera_sources", "get_source", "register",
           "sources_for_kind"]
