"""The outcome of one generated recording calibrated by the ``calibrate`` command
(:class:`Outcome`) and the acceptance checks of docs/recordings.md
(:func:`acceptance_failures`), used by :mod:`simcalib.studies.experiments.recordings` and
its tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.studies.experiments.recording_kinds import KINDS

__all__ = ["PARK_FACTOR", "ROT_FLOOR_DEG", "TRANS_FLOOR_MM", "OFFSET_TOL_MS", "STEP_TOL_S",
           "MIN_PRECISION", "MIN_RECALL", "Outcome", "offset_checked", "no_worse",
           "acceptance_failures", "mount_failures", "step_failures"]

#: acceptance (tests/test_studies_experiments_recordings.py): errors <= max(PARK_FACTOR x
#: Park's, floor), the offset within OFFSET_TOL_MS where the data determine it, outlier
#: motions rejected
PARK_FACTOR = 1.5
ROT_FLOOR_DEG = 0.05
TRANS_FLOOR_MM = 0.5
OFFSET_TOL_MS = 3.0
#: a clock step told at b's first pose after it: within this (s; less than a 30 Hz frame)
STEP_TOL_S = 0.02
MIN_PRECISION = 0.95
MIN_RECALL = 0.5


@dataclass(frozen=True)
class Outcome:
    """One calibration of one recording by the ``calibrate`` command (defaults) and the
    Park baseline (``park_oracle_*``: Park on the outlier-free instants, for kinds with
    outliers; a reference only). Errors in degrees / millimetres (translation without the
    undetermined direction, if any); NaN where there is no estimate. ``reading_ok``: the
    detected reading (invert, scalar order of both files) is the true one (None without a
    calibration);
    ``offset_error_ms``: estimated minus true offset at the recording's ``t_ref_s`` (NaN
    where it is not checked: :func:`offset_checked`); ``precision`` / ``recall``: of the
    calibration's inlier motions against the motions that touch no outlier pose;
    ``undetermined_dirs_a``: the translation directions (frame a) the calibration reported
    as undetermined / poorly determined, ``undetermined_flagged``: one of them is within
    25 deg of the recording's undetermined direction; ``mount_change_s``: the two instants
    (clock a) between which the calibration told X changed (``mount_change``), () where it
    told none; ``true_change_s``: the instants either side of the true change (kinds whose
    X changes, else ()); ``steps``: the clock steps of b told, ``(at_a_s, size_s)`` each;
    ``true_step``: the true one's (kinds whose clock steps: the instant of b's first pose
    after it, on a's clock), else (); ``message``: the command's error line."""
    kind: str
    seed: int
    exit_code: int
    runtime_s: float
    rot_error_deg: float = math.nan
    trans_error_mm: float = math.nan
    park_rot_error_deg: float = math.nan
    park_trans_error_mm: float = math.nan
    park_oracle_rot_error_deg: float = math.nan
    park_oracle_trans_error_mm: float = math.nan
    offset_error_ms: float = math.nan
    reading_ok: bool | None = None
    precision: float = math.nan
    recall: float = math.nan
    undetermined_dirs_a: tuple = ()
    undetermined_flagged: bool = False
    mount_change_s: tuple = ()
    true_change_s: tuple = ()
    steps: tuple = ()
    true_step: tuple = ()
    message: str = ""


def offset_checked(kind) -> bool:
    """The offset found is held to the truth: the data determine it (continuous motion),
    or the kind states how close it must be found (``offset_tol_ms``: a camera on another
    clock that sees only at the stops, found to the stop)."""
    return kind.offset_determined or kind.offset_tol_ms is not None


def no_worse(error, park_error, floor) -> bool:
    """``error <= max(PARK_FACTOR x park_error, floor)``; both NaN (no translation of X is
    determined, pure translation) passes: there is nothing to compare."""
    if math.isnan(error) and math.isnan(park_error):
        return True
    return error <= max(PARK_FACTOR * park_error, floor)


def acceptance_failures(o: Outcome) -> list[str]:
    """The acceptance criteria that ``o`` fails (the same as the tests):
    ``exit`` (0 or 6 for valid data, 6 for degenerate kinds, 3 for bad input), ``accuracy``
    (vs Park), ``accuracy vs inlier Park`` (kinds with outliers: vs Park on the outlier-free
    instants, since Park without rejection is no bar there), ``offset``, ``reading``,
    ``flag`` (undetermined direction reported), ``inliers`` (outlier kinds)."""
    kind = KINDS[o.kind]
    if kind.expect == "data_error":
        return [] if o.exit_code == 3 else ["exit"]
    if o.exit_code not in (0, 6) or not math.isfinite(o.rot_error_deg):
        return ["exit"]
    out = [] if (o.exit_code == 6 or kind.expect != "degenerate") else ["exit"]
    if not (no_worse(o.rot_error_deg, o.park_rot_error_deg, ROT_FLOOR_DEG)
            and no_worse(o.trans_error_mm, o.park_trans_error_mm, TRANS_FLOOR_MM)):
        out.append("accuracy")
    if math.isfinite(o.park_oracle_rot_error_deg) and not (
            no_worse(o.rot_error_deg, o.park_oracle_rot_error_deg, ROT_FLOOR_DEG)
            and no_worse(o.trans_error_mm, o.park_oracle_trans_error_mm, TRANS_FLOOR_MM)):
        out.append("accuracy vs inlier Park")
    tol_ms = OFFSET_TOL_MS if kind.offset_tol_ms is None else kind.offset_tol_ms
    if offset_checked(kind) and not abs(o.offset_error_ms) <= tol_ms:
        out.append("offset")
    if not o.reading_ok:
        out.append("reading")
    if kind.expect == "degenerate" and not o.undetermined_flagged:
        out.append("flag")
    if "outlier_fraction" in kind.extra and not (o.precision >= MIN_PRECISION
                                                 and o.recall >= MIN_RECALL):
        out.append("inliers")
    return out + mount_failures(o) + step_failures(o)


def mount_failures(o: Outcome) -> list[str]:
    """``mount change`` (X changed: not told, or told elsewhere than between the rows
    either side of the change) or ``false mount change`` (told where X never changed)."""
    if not o.true_change_s:
        return ["false mount change"] if o.mount_change_s else []
    told = len(o.mount_change_s) == 2 and np.allclose(o.mount_change_s, o.true_change_s)
    return [] if told else ["mount change"]


def step_failures(o: Outcome) -> list[str]:
    """``clock step`` (b's clock stepped: not told as one step of the true size within
    :data:`OFFSET_TOL_MS`, at b's first pose after it within :data:`STEP_TOL_S`) or
    ``false clock step`` (told where the clock never stepped)."""
    if not o.true_step:
        return ["false clock step"] if o.steps else []
    ok = len(o.steps) == 1 and abs(o.steps[0][1] - o.true_step[1]) <= 1e-3 * OFFSET_TOL_MS \
        and abs(o.steps[0][0] - o.true_step[0]) <= STEP_TOL_S
    return [] if ok else ["clock step"]
