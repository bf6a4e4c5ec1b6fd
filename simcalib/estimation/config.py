"""The ``estimation.*`` section of a scenario: how a run turns its two measured pose
streams into the motions its solvers get — the paper's pairing (appendix D.1, the stamps
taken as they are), or the path that calibrates recorded files (``simcalib calibrate``):
sampling, reading, clock offset, motion policy, outliers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from simcalib.config.checks import check_positive, check_range, check_that, set_fields
from simcalib.config.engine import key_help

__all__ = ["EstimationConfig", "FILE_FORMS"]

#: how stream b is handed to the estimation path (a simulated file's form)
FILE_FORMS = ("as_written", "inverted", "scalar_first", "inverted_scalar_first")



@dataclass(frozen=True)
class EstimationConfig:
    """``estimation.*``. ``motions=pairing`` is the paper's D.1 pairing (``pairing.*``) of
    the streams as stamped; any other policy runs the recorded-data path of ``calibrate``
    on the run's streams, with everything it decides scored against the truth in
    results.json ``estimation``."""
    motions: Literal["pairing", "auto", "stations", "bursts", "spans", "consecutive",
                     "keyframes"] = \
        field(default="pairing", metadata=key_help(
            "pairing: the paper's D.1 pairing (pairing.*); auto/stations/bursts/spans/"
            "consecutive/keyframes: the calibrate path's motion policy (auto: chosen from "
            "the data)"))
    time_offset: Literal["stamps", "estimate"] | float = field(default="stamps", metadata=key_help(
        "stamps: the stamps as they are; estimate: the clock offset estimated where the "
        "data tell it (calibrate's default); a number: t_b - t_a in seconds"))
    reading: Literal["as_written", "detect"] = field(default="as_written", metadata=key_help(
        "as_written: the streams read as delivered; detect: inverse poses and quaternion "
        "order decided from the data (calibrate's default)"))
    robust: Literal["none", "auto", "ransac", "irls"] = field(default="none", metadata=key_help(
        "outlier motions: none, or calibrate's auto / ransac / irls; the solvers get the "
        "inliers"))
    b_file: Literal["as_written", "inverted", "scalar_first", "inverted_scalar_first"] = field(
        default="as_written", metadata=key_help(
            "how stream b is handed over, as a file might hold it: inverted (T_cam_world), "
            "scalar_first (quaternion numbers w first read as x first), or both"))
    step_s: float = field(default=1.0, metadata=key_help(
        "consecutive motions span this time step, s"))
    min_rotation_deg: float = field(default=2.0, metadata=key_help(
        "motions rotating less are dropped (recorded-data path)"))

    def __post_init__(self):
        if self.time_offset not in ("stamps", "estimate"):
            set_fields(self, time_offset=check_range("time_offset", self.time_offset))
        set_fields(self, step_s=check_positive("step_s", self.step_s),
                   min_rotation_deg=check_range("min_rotation_deg", self.min_rotation_deg,
                                                lo=0.0, hi=180.0))
        if self.motions == "pairing":
            for key, paper in (("time_offset", "stamps"), ("reading", "as_written"),
                               ("robust", "none"), ("b_file", "as_written")):
                check_that(getattr(self, key) == paper, key, getattr(self, key),
                           f"{paper!r} with motions=pairing (the paper's pairing takes the "
                           "streams as stamped and written); choose motions=auto for the "
                           "recorded-data path")

    @property
    def recorded(self) -> bool:
        """The run goes through calibrate's recorded-data path."""
        return self.motions != "pairing"
