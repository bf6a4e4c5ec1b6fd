"""The one estimation path, stage by stage (:func:`calibrate_streams`; the library core of
``python -m simcalib calibrate`` and, through :mod:`simcalib.estimation.streams`, of a run's
``estimation.*``):

    read (simcalib.importers) -> sampling (estimation.sampling) -> reading and clock offset
    (:func:`align_and_read`: estimation.reading_alignment) -> synchronised poses
    -> motions (estimation.motions) -> outliers (estimation.outliers) -> the final solve
    with the motions' shared poses -> the covariance checked by the data
    (estimation.consistency) -> (the verdict: estimation.verdict); and, for comparison, a
    plain solve (offset 0, no rejection).

A stream whose world frame jumps (a SLAM map reset, a bumped target:
:mod:`simcalib.estimation.world_jumps`) is used whole: each stretch between jumps is its own
world, every motion lies within one, and every stage after uses the motions of all
stretches. Where X itself changes at one instant (a camera bumped on its mount:
:mod:`simcalib.estimation.mount`), the change is marked the same way and the fit keeps
the stretch with more poses (:func:`_mount_pass`).

A rig that only translates (neither stream turns:
:func:`~simcalib.estimation.stillness.check_streams_move` returns ``translation``) goes
through the same stages on its translations: the offset from the translation speeds, the
readings scored on motions that translate, no rotation filter, RANSAC sets by translation
direction; X's rotation follows from ``t_C = R_X t_H`` and its translation is reported
undetermined on every axis (exit 6).

Measured on public recordings by ``python -m simcalib.studies.experiments.real_data``, on generated
ones by ``python -m simcalib.studies.experiments.recordings``, in simulation by ``python -m simcalib
experiment streams``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import NamedTuple
from pathlib import Path

import numpy as np

from simcalib.estimation.added_covariance import with_common_error, with_scale
from simcalib.estimation.outliers import robust_fit
from simcalib.estimation.reading_alignment import align_and_read, first_reading  # noqa: F401
from simcalib.estimation.stillness import check_distinct, check_streams_move

__all__ = ["StreamCalibration", "calibrate_streams", "align_and_read", "first_reading"]


@dataclass(frozen=True, eq=False)
class StreamCalibration:
    """Everything one calibration of two streams produced.

    ``X``: ``T_a_b`` (robust); ``X_plain``: the synchronous solve without rejection
    (offset 0, all motions); ``time_offset``:
    :class:`simcalib.estimation.alignment.TimeOffset`; ``conventions``:
    :class:`simcalib.estimation.readings.ConventionReport`; ``robust`` / ``plain``:
    :class:`simcalib.solvers.robust.RobustSolution`; ``C``, ``H`` the motions used,
    ``motion_time_s`` their start instants (clock a); ``summary``: numbers for reports;
    ``synced``: the synchronised poses
    (:class:`simcalib.estimation.alignment.SyncedPoses`) the motions were formed from;
    ``motion_index``: ``(i, j)``, motion k runs from ``synced`` instant ``i[k]`` to
    ``j[k]``; ``X_aligned``: dqopt on the same motions without rejection;
    ``sampling``: :class:`simcalib.estimation.sampling.Sampling`; ``motions``: the
    :class:`~simcalib.estimation.motions.MotionSet`; ``consistency``: the jackknife check
    (:class:`~simcalib.estimation.consistency.Consistency`); ``covariance`` /
    ``covariance_determined``: the reported 6x6 (the model's, raised where the data are
    less consistent than it says); ``robust_choice``: why that outlier handling;
    ``weighting``: the :class:`~simcalib.estimation.consistency.WeightingCheck`.
    """
    X: np.ndarray
    X_plain: np.ndarray
    time_offset: object
    conventions: object
    robust: object
    plain: object
    stream_a: object
    stream_b: object
    C: np.ndarray = field(repr=False)
    H: np.ndarray = field(repr=False)
    motion_time_s: np.ndarray = field(repr=False)
    summary: dict = field(default_factory=dict)
    synced: object = field(default=None, repr=False)
    motion_index: tuple = field(default=(), repr=False)
    X_aligned: np.ndarray | None = field(default=None, repr=False)
    sampling: object = None
    motions: object = field(default=None, repr=False)
    consistency: object = None
    covariance: np.ndarray | None = field(default=None, repr=False)
    covariance_determined: np.ndarray | None = field(default=None, repr=False)
    robust_choice: str = ""
    weighting: object = None
    #: the stated error common to every pose (:class:`simcalib.estimation.common_error.
    #: CommonError`) added to the covariance; None: not stated
    common_error: object = None
    #: how the rig moves (:func:`check_streams_move`): ``rotation``, or ``translation``
    #: (nothing turns: X's rotation from the translations, its translation undetermined)
    signal: str = "rotation"
    #: the scale of b's translations used (:class:`simcalib.estimation.scale.ScaleDecision`)
    scale: object = None


def _errors_summary(C, H, X, mask=None):
    from simcalib.solvers.robust import constraint_errors
    r, t = constraint_errors(C, H, X)
    if mask is not None:
        r, t = r[mask], t[mask]
    if r.size == 0:
        return {"rot_median_deg": None, "rot_rms_deg": None, "trans_median_mm": None,
                "trans_rms_mm": None}
    return {"rot_median_deg": float(np.degrees(np.median(r))),
            "rot_rms_deg": float(np.degrees(np.sqrt(np.mean(r**2)))),
            "trans_median_mm": float(1e3 * np.median(t)),
            "trans_rms_mm": float(1e3 * np.sqrt(np.mean(t**2)))}


def _pose_summary(X):
    from simcalib.geometry import quat_from_matrix, rotvec_from_matrix
    return {"t_m": X[:3, 3].tolist(), "q_xyzw": quat_from_matrix(X[:3, :3]).tolist(),
            "rotvec_deg": np.degrees(rotvec_from_matrix(X[:3, :3])).tolist()}


def _read(s, fmt, unit="auto", recording=None):
    """A stream of a path (its stamps' unit: given, or left for the pair to tell;
    ``recording``: of a file holding several, that one) or as given."""
    from simcalib.importers import PoseStreamData, read_pose_stream
    if isinstance(s, PoseStreamData):
        return s
    return read_pose_stream(s, fmt, stamps_unit="pair" if unit in (None, "auto") else unit,
                            recording=recording)


def _same_recording(a, b, sa, sb, read_a, read_b):
    """``(sa, sb)`` of the same recording of two files that each hold as many (a logger
    restarted in both, each file keeping its longest): the number whose shorter stream is
    longest, so that the robot's first session is not paired with the camera's second."""
    n = [s.repairs.get("recordings_in_file") for s in (sa, sb)]
    if n[0] is None or n[0] != n[1] or not all(isinstance(x, (str, Path)) for x in (a, b)) \
            or sa.repairs["recording_kept"] == sb.repairs["recording_kept"]:
        return sa, sb
    pairs = [(read_a(k), read_b(k)) for k in range(1, n[0] + 1)]
    return max(pairs, key=lambda p: min(p[0].duration_s, p[1].duration_s))


def read_files(a, b, format_a=None, format_b=None, unit_a="auto", unit_b="auto"):
    """Both streams (paths or PoseStreamData) as read (stamps as :func:`_read`), of the
    same recording where both files hold several (:func:`_same_recording`)."""
    return _same_recording(a, b, _read(a, format_a, unit_a), _read(b, format_b, unit_b),
                           lambda k: _read(a, format_a, unit_a, k),
                           lambda k: _read(b, format_b, unit_b, k))


def read_pair(a, b, format_a=None, format_b=None, unit_a="auto", unit_b="auto"):
    """Both streams of :func:`read_files` with their stamps in seconds where the data
    tell the unit (:func:`simcalib.estimation.stamp_units.stamps_to_seconds`; ``unit_a`` /
    ``unit_b``: ``auto`` or the unit given)."""
    from simcalib.estimation.stamp_units import stamps_to_seconds
    sa, sb = read_files(a, b, format_a, format_b, unit_a, unit_b)
    return stamps_to_seconds(sa, sb, unit_a, unit_b)


def synchronised(sa, sb, sampling, off):
    """The synchronised poses: paired by stamp, or b interpolated at a's shifted stamps."""
    from simcalib.estimation.sampling import pair_by_stamp
    from simcalib.estimation.alignment import synchronise
    if sampling.paired_by_stamp:
        return pair_by_stamp(sa, sb, sampling, off.offset_s)
    return synchronise(sa, sb, off)


def _final_solve(motions, rob, *, method, alpha, prior, seed, tolerances=None):
    """The estimate on the inliers and its residuals on every motion. Its uncertainty
    (the solver's model) serves for the directions the motions determine; the reported
    covariance comes from the poses' own errors (:func:`_consistency`)."""
    from simcalib.solvers.api import solve
    from simcalib.solvers.robust import screw_residuals
    m = rob.inlier_mask
    C, H = motions.C[m], motions.H[m]
    kw = {}
    if tolerances is not None:
        kw |= {"tolerance_deg": tolerances.tolerance_deg,
               "tolerance_m": tolerances.tolerance_m}
    sol = solve(C, H, method=method, alpha=alpha, prior=prior,
                         rng=np.random.default_rng(seed), **kw)
    msg = rob.message + (f"; final {method} with the prior" if prior is not None else "")
    return dataclasses.replace(rob, X=sol.X, solution=sol, message=msg,
                               residuals=screw_residuals(motions.C, motions.H, sol.X, alpha))


def _consistency(motions, rob, synced, *, method, alpha, prior, offset_sigma_s=0.0):
    """``(check, WeightingCheck, covariance, covariance_determined)``: without a prior, X's
    covariance from the poses' own errors (:func:`simcalib.estimation.consistency.
    pose_consistency`: white and correlated parts, checked by the recording's two halves);
    with a prior, the model's covariance raised to the block jackknife. Then the move of X
    under a rotation-weighted cost is added when it is beyond the sigma."""
    from simcalib.estimation.consistency import (block_jackknife, combine, pose_consistency,
                                                 weighting_check)
    from simcalib.solvers.api import solve
    sol = rob.solution
    if sol is None or sol.uncertainty is None:
        return None, None, None, None
    inl = motions.subset(rob.inlier_mask)
    solve_at = lambda C, H, a: solve(C, H, method=method, alpha=a,  # noqa: E731
                                             prior=prior).X
    if prior is None:
        check = pose_consistency(inl, synced, sol.X, alpha,
                                 sol.uncertainty.determined_basis,
                                 lambda C, H: solve_at(C, H, alpha), offset_sigma_s)
        cov, cov_det = _projected(sol.uncertainty, check.covariance, check.basis,
                                  check.undetermined)
    else:
        check = block_jackknife(inl, synced.n, lambda C, H: solve_at(C, H, alpha), sol.X)
        cov, cov_det, ratio = combine(sol.uncertainty, check)
        raised = bool(check.checked and not np.array_equal(
            cov_det, np.asarray(sol.uncertainty.covariance_determined)))
        check = dataclasses.replace(check, ratio=ratio, raised=raised)
    weighting = weighting_check(inl.C, inl.H, sol.X, sol.uncertainty, cov_det, solve_at,
                                alpha)
    if weighting is not None and weighting.significant:
        fin = np.isfinite(cov)
        cov = cov.copy()
        cov[fin] = cov[fin] + weighting.covariance[fin]
        cov_det = cov_det + weighting.covariance
    return check, weighting, cov, cov_det


def _offset_sigma(off) -> float:
    """The 1-sigma of the clock offset used, for X's covariance: 0 for a given offset and
    for stamps shared as they are (stations) or after a constant shift; for stamps shared
    by two continuous streams whose motions did not tell an offset from 0, the check's
    bound (:func:`simcalib.estimation.hidden_offset.kept_at_zero`); 0 where it is unknown
    (NaN: nothing to add), and for an offset put where b's clusters fall on a's stops
    (``at_stops``): within its sigma b's samples stay where a stands still, so an error
    there pairs them with the same poses of a (b's velocities there are its pose noise
    differenced, and the gaps between its stops: its sigma of ~0.2 s on them widened X's
    sigma 4x)."""
    if off.decision == "given" or off.at_stops:
        return 0.0
    s = float(off.uncertainty_s)
    return s if math.isfinite(s) and s > 0 else 0.0


def _projected(uncertainty, C, basis=None, undetermined=None):
    """``(covariance, covariance_determined)``: ``C`` (6x6; None: the model's own) on the
    determined directions ``basis`` (default the model's), ``inf`` where the model has it
    and on the axes the ``undetermined`` directions (6, u) touch."""
    from simcalib.solvers.diagnostics.inputs import _PURE
    cov = np.asarray(uncertainty.covariance, dtype=np.float64)
    if C is None:
        return cov, np.asarray(uncertainty.covariance_determined, dtype=np.float64)
    B = np.asarray(uncertainty.determined_basis if basis is None else basis)
    cov_det = B @ (B.T @ C @ B) @ B.T
    cov_det = 0.5 * (cov_det + cov_det.T)
    out = cov.copy()
    fin = np.isfinite(out)
    out[fin] = cov_det[fin]
    if undetermined is not None and undetermined.shape[1]:
        # as the model does: the axes a direction touches, in tolerance units
        dsc = np.array([math.radians(uncertainty.tolerance_deg)] * 3
                       + [uncertainty.tolerance_m] * 3)
        Ut = undetermined / dsc[:, None]
        Ut = Ut / np.linalg.norm(Ut, axis=0)
        touched = np.linalg.norm(Ut, axis=1) > _PURE
        out[touched, :] = 0.0
        out[:, touched] = 0.0
        out[touched, touched] = np.inf
    return out, cov_det


def calibrate_streams(a, b, *, format_a: str | None = None, format_b: str | None = None,
                      time_offset="estimate", robust: str = "auto", alpha: float = 1.0,
                      step_s: float = 1.0, min_rotation_deg: float = 2.0,
                      max_rotation_deg: float | None = None, invert_a: bool | None = None,
                      invert_b: bool | None = None, scalar_first_a: bool | None = None,
                      scalar_first_b: bool | None = None, drift="auto",
                      robust_options: dict | None = None, method: str = "dqopt",
                      prior=None, seed: int = 0, motions: str = "auto",
                      tolerances=None, common_error=None, stamps_unit_a: str = "auto",
                      stamps_unit_b: str = "auto", scale_b="auto",
                      mirror_b: bool | None = None) -> StreamCalibration:
    """Calibrate ``X = T_a_b`` from two pose streams (paths or PoseStreamData), the one path:
    jumps of a world frame (:mod:`~simcalib.estimation.world_jumps`) -> how the rig moves
    (:func:`check_streams_move`) -> sampling (:mod:`~simcalib.estimation.sampling`) ->
    reading and clock offset (:func:`align_and_read`; ``time_offset``: ``"estimate"`` or
    seconds ``t_b - t_a``) -> synchronised poses -> motions (``motions``: ``auto`` or a
    policy of :mod:`simcalib.estimation.motions`; ``step_s``; rotation below
    ``min_rotation_deg`` (unless nothing turns) / above ``max_rotation_deg`` dropped) ->
    outliers (``robust``: ``auto``, ``ransac``, ``irls``, ``none``) -> ``method`` on the
    inliers (``prior``: a :class:`simcalib.Prior`) -> uncertainty and its check;
    ``tolerances``: :class:`simcalib.estimation.verdict.Tolerances` (1 deg / 1 cm);
    ``common_error``: a stated :class:`~simcalib.estimation.common_error.CommonError`;
    ``stamps_unit_a`` / ``_b``: :func:`read_pair`; ``scale_b``: ``auto``, ``estimate`` or a
    number (:mod:`simcalib.estimation.scale`); ``mirror_b``: None (told by the data:
    :func:`align_and_read`), or b forced mirrored (True) or as written (False). Bad input
    raises a DataError."""
    from simcalib.estimation.scale import check_scale_b
    scale_b = check_scale_b(scale_b)
    sa0, sb0, sampling, signal, notes = _prepared(a, b, (format_a, format_b),
                                                  (stamps_unit_a, stamps_unit_b), scale_b)
    min_rotation_deg = min_rotation_deg if signal == "rotation" else None
    kw = dict(time_offset=time_offset, drift=drift, alpha=alpha, seed=seed, signal=signal,
              forced={"invert_a": invert_a, "invert_b": invert_b,
                      "scalar_first_a": scalar_first_a, "scalar_first_b": scalar_first_b,
                      "mirror_b": mirror_b},
              motions=motions, step_s=step_s, min_rotation_deg=min_rotation_deg,
              max_rotation_deg=max_rotation_deg, robust=robust, method=method,
              robust_options=robust_options)
    p, scale = _scale_pass(_fit_pass(sa0, sb0, sampling, **kw), sa0, sb0, sampling, scale_b, kw)
    p, ms_all, mount, notes = _mount_pass(p, sa0, sb0, sampling, scale, kw, notes)
    sa, sb, conv, off, sp, ms, length_scale, rob, why, sampling = p
    prior = _per_pass(prior, ms.passes)
    rob = _final_solve(ms, rob, method=method, alpha=alpha, prior=prior, seed=seed,
                       tolerances=tolerances)
    check, weighting, cov, cov_det = _consistency(
        ms, rob, sp, method=method, alpha=alpha, prior=prior, offset_sigma_s=_offset_sigma(off))
    cov, cov_det, common_error = with_common_error(cov, cov_det, rob, check, common_error)
    cov, cov_det = with_scale(cov, cov_det, rob, check, ms, scale, alpha)
    ms0, plain = _plain(sa, sb, sampling, off, sp, ms_all, step_s=step_s, alpha=alpha,
                        min_rotation_deg=min_rotation_deg, max_rotation_deg=max_rotation_deg)
    aligned, summary = _summary(sa, sb, conv, off, ms, rob, ms0, plain, alpha, length_scale)
    return StreamCalibration(rob.X, None if plain is None else plain.X, off, conv, rob, plain,
                             sa, sb, ms.C, ms.H, sp.time_s[ms.i], summary | _notes(
                                 notes, sp, ms, rob, mount) | {"scale_b": scale.to_dict()},
                             synced=sp, motion_index=(ms.i, ms.j),
                             X_aligned=aligned.X, sampling=sampling, motions=ms,
                             consistency=check, covariance=cov, covariance_determined=cov_det,
                             robust_choice=why, weighting=weighting,
                             common_error=common_error, signal=signal, scale=scale)


def _prepared(a, b, formats, units, scale_b) -> tuple:
    """The streams as the fit takes them (read, b's given scale applied, world jumps
    marked, station rows re-paired, station groups split): ``(stream_a, stream_b,
    sampling, signal (:func:`check_streams_move`), (world-jump notes, row notes))``."""
    from simcalib.estimation.sampling import classify_sampling
    from simcalib.estimation.scale import MODES, scaled_stream
    from simcalib.estimation.station_rows import realign_rows
    from simcalib.estimation.world_jumps import mark_stretches, split_stations
    sa0, sb0 = read_pair(a, b, *formats, *units)
    check_distinct(sa0, sb0)
    if scale_b not in MODES:                # a scale given: b's translations divided by it
        sb0 = scaled_stream(sb0, 1.0 / float(scale_b))
    sa0, sb0, jumps = mark_stretches(sa0, sb0)
    signal = check_streams_move(sa0, sb0)
    sa0, sb0, sampling, rows = realign_rows(sa0, sb0, classify_sampling(sa0, sb0))
    sa0, sb0, split = split_stations(sa0, sb0, sampling)
    return sa0, sb0, sampling, signal, (jumps + split, rows, split)


def _notes(notes, sp, ms, rob, mount) -> dict:
    """The summary's sentences on station rows, world jumps (and the stretches the fit
    used, unless X changed: its warning says which) and the change of X
    (``mount_change``: its record, None)."""
    from simcalib.estimation.world_jumps import stretches_used
    return {"station_rows": notes[1], "mount_change": mount,
            "world_jumps": notes[0] + ([] if mount else stretches_used(sp, ms, rob))}


def _stepped(p, sa0, sb0, sampling, scale, kw, cut_s: float):
    """``(pass, b)`` formed again on b's stamps with a clock step at ``cut_s`` (clock a)
    removed, where the offset was estimated on streams not paired by stamp and the
    stretches either side tell one that holds (:func:`simcalib.estimation.clock_step.
    step_at`, :func:`~simcalib.estimation.clock_step.holds`): a clock that steps misaligns
    the motions of one stretch, which the offset's own checks may not see (the offset
    fitted to the other, those motions dropped as outliers), and each stretch's own X
    then fits it better, as where X changed. Else None."""
    from dataclasses import replace
    from simcalib.estimation.clock_step import holds, shifted, step_at
    from simcalib.estimation.scale import scaled_stream
    if kw["time_offset"] != "estimate" or sampling.paired_by_stamp or p.off.drift != 0.0:
        return None
    by = "auto" if kw["signal"] == "rotation" else kw["signal"]
    step = step_at(p.sa, p.sb, p.off, cut_s, alpha=kw["alpha"], signal=by)
    if step is None:
        return None
    sb1 = shifted(sb0, step)
    rescaled = scale.rescaled and scale.decision == "rescaled"
    p2 = _fit_pass(sa0, scaled_stream(sb1, 1.0 / scale.used) if rescaled else sb1,
                   sampling, **kw)
    if not holds(step, p2.off):
        return None
    off = replace(p2.off, steps=(*p2.off.steps, step), message=f"{step.line()}; "
                  f"{p2.off.message}")
    return p2._replace(off=off), sb1


def _mount_pass(p, sa0, sb0, sampling, scale, kw, notes, step_search=True):
    """``(pass, all its motions, mount_change, notes)``: where X changes at one instant
    (:func:`simcalib.estimation.mount.find_mount_change`) the pass formed again with the
    change marked as a world jump (unless one is marked there already; b's scale as
    decided), its motions kept to the stretch whose X is reported and fitted again;
    ``mount_change`` the change's record for calibration.json, ``notes`` with its warning
    in place of a station split's (the same split, taken for a world jump). Else, and
    where the reading of that pass is not clear (a mirrored b fits no proper X: each
    stretch's own fits it better, and nothing is told by that), as given (``mount_change``
    None)."""
    from simcalib.estimation import mount as mc
    from simcalib.estimation.scale import scaled_stream
    fit = dict(alpha=kw["alpha"], method=kw["method"], seed=kw["seed"])
    change = mc.find_mount_change(p.sp, p.ms, **fit)
    if change is None:
        return p, p.ms, None, notes
    stepped = _stepped(p, sa0, sb0, sampling, scale, kw, change.cut_s) if step_search else None
    if stepped is not None:                 # b's clock stepped there: X did not change
        return _mount_pass(stepped[0], sa0, stepped[1], sampling, scale, kw, notes,
                           step_search=False)
    p0 = p
    edge = mc.on_world_edge(p.sp, change.index)
    if not edge:
        sa1, sb1 = mc.mark_change(sa0, sb0, change.cut_s, p.off.offset_s)
        if scale.rescaled and scale.decision == "rescaled":
            sb1 = scaled_stream(sb1, 1.0 / scale.used)
        p2 = _fit_pass(sa1, sb1, sampling, **kw)
        k = int(np.searchsorted(p2.sp.time_s, change.cut_s))
        change = mc.describe_split(p2.sp, p2.ms, k, change.misfit_ratio, **fit)
        if change is None:                  # the pass with the change marked lost a side
            return p, p.ms, None, notes
        p = p2
    if not p.conv.clear:    # no reading fits: the stretches' own X's tell no changed mount
        return p0, p0.ms, None, notes
    ms = p.ms.subset(mc.kept_motions(p.ms, change))
    rob, why = robust_fit(ms.C, ms.H, kw["robust"], alpha=kw["alpha"], method=kw["method"],
                          seed=kw["seed"], options=kw["robust_options"])
    world = [n for n in notes[0] if not edge or n not in notes[2]]
    return (p._replace(ms=ms, rob=rob, why=why), p.ms, change.to_dict(),
            ([change.sentence(p.off.offset_s)] + world, notes[1], notes[2]))


def _scale_pass(p, sa0, sb0, sampling, scale_b, kw):
    """``(pass, ScaleDecision)``: the scale of b's translations decided on the first pass
    ``p`` (:func:`simcalib.estimation.scale.decide_for`); where it rescales, the path runs
    once more with b's translations divided by it, and the scale is estimated again on it
    (the check, ~1)."""
    from simcalib.estimation.scale import decide_for, estimate_for, scaled_stream
    alpha = kw["alpha"]
    scale = decide_for(p.ms, p.sp, p.rob.inlier_mask, scale_b, alpha, UNITS_HINT)
    if scale.rescaled and scale.decision == "rescaled":
        p = _fit_pass(sa0, scaled_stream(sb0, 1.0 / scale.used), sampling, **kw)
        scale = dataclasses.replace(scale, check=estimate_for(p.ms, p.sp, p.rob.inlier_mask,
                                                             alpha))
    return p, scale


def _fit_pass(sa0, sb0, sampling, *, time_offset, drift, alpha, seed, signal, forced,
              motions, step_s, min_rotation_deg, max_rotation_deg, robust, method,
              robust_options):
    """One pass of the path from the streams as read to the robust fit: reading and
    clock offset, synchronised poses, motions (fewer than 2 refused), outliers (the
    streams' length units are judged with their scale: :func:`simcalib.estimation.scale.
    decide_for`). Returns ``(stream_a, stream_b, conventions,
    offset, synced, motions, pitch scale, RobustSolution, why)``."""
    from simcalib.estimation.motions import form_motions
    sa, sb, conv, off, sampling = align_and_read(
        sa0, sb0, sampling, time_offset=time_offset, drift=drift, alpha=alpha, seed=seed,
        forced=forced, signal=signal)
    sp = synchronised(sa, sb, sampling, off)
    step_s = _step(sampling, step_s)
    ms = form_motions(sp, motions, paired_by_stamp=sampling.paired_by_stamp,
                      index_stamps=_stations_by_index(sampling), step_s=step_s,
                      min_rotation_deg=min_rotation_deg, max_rotation_deg=max_rotation_deg)
    length_scale = _check_motions(ms, sp)
    rob, why = robust_fit(ms.C, ms.H, robust, alpha=alpha, method=method, seed=seed,
                          options=robust_options)
    return _Pass(sa, sb, conv, off, sp, ms, length_scale, rob, why, sampling)


def _step(sampling, step_s: float) -> float:
    """The motions' base step: ``step_s``, or for sample-number stamps of a continuous
    motion the step in samples chosen from the motion (``Sampling.motion_step``)."""
    return float(sampling.motion_step) if getattr(sampling, "motion_step", 0) else step_s


def _stations_by_index(sampling) -> bool:
    """Sample-number stamps whose poses are stations (not a continuous motion)."""
    return sampling.kind == "index_stamps" and not getattr(sampling, "motion_step", 0)


class _Pass(NamedTuple):
    sa: object
    sb: object
    conv: object
    off: object
    sp: object
    ms: object
    length_scale: float
    rob: object
    why: str
    sampling: object


def _check_motions(ms, sp) -> float:
    """DataError for fewer than 2 motions; returns b's length scale against a's by the
    pitch invariant (:func:`simcalib.estimation.units.pitch_scale`; NaN: the motions
    cannot tell)."""
    from simcalib.estimation.units import pitch_scale
    if ms.n < 2:
        from simcalib.errors import DataError
        raise DataError(f"only {ms.n} motion(s) from {sp.n} synchronised poses ({ms.reason};"
                        f" {ms.counts}); at least 2 rotating motions are needed")
    return pitch_scale(ms.C, ms.H)[0]


#: how the refusal of streams in different units is answered (``scale_b``, docs/calibrate.md)
UNITS_HINT = ("write both in metres, or give scale_b=estimate (b's translations divided by "
              "their estimated scale, its uncertainty in X's sigma) or scale_b=<b's "
              "translations over a metric b's: 1000 for b in mm against a in m>")


def _summary(sa, sb, conv, off, ms, rob, ms0, plain, alpha, length_scale) -> tuple:
    """``(aligned, summary)``: the aligned solve (offset applied, no rejection) and
    ``StreamCalibration.summary``: the streams, the reading, the offset, the motions and
    inliers, X and its residuals, beside the plain solve's (offset 0, every motion, no
    rejection) and the aligned one's."""
    from simcalib.solvers.robust import robust_solve
    C, H = ms.C, ms.H
    aligned = robust_solve(C, H, "none", alpha=alpha)
    return aligned, {
        "a": sa.describe(), "b": sb.describe(), "conventions": conv.message,
        "offset_ms": 1e3 * off.offset_s, "offset_sigma_ms": 1e3 * off.uncertainty_s,
        "offset_message": off.message, "n_motions": int(C.shape[0]),
        "n_inliers": rob.n_inliers, "robust_message": rob.message,
        "X": _pose_summary(rob.X),
        "X_plain": None if plain is None else _pose_summary(plain.X),
        "residuals_inliers": _errors_summary(C, H, rob.X, rob.inlier_mask),
        "residuals_all": _errors_summary(C, H, rob.X),
        "residuals_plain": None if plain is None else _errors_summary(ms0.C, ms0.H, plain.X),
        "n_motions_plain": None if plain is None else int(ms0.C.shape[0]),
        "X_aligned": _pose_summary(aligned.X),
        "residuals_aligned": _errors_summary(C, H, aligned.X),
        "rot_diff_deg": None if plain is None else float(np.degrees(_rot_angle(rob.X,
                                                                               plain.X))),
        "trans_diff_mm": None if plain is None else float(
            1e3 * np.linalg.norm(rob.X[:3, 3] - plain.X[:3, 3])),
        "degenerate": bool(rob.solution.degenerate) if rob.solution is not None else None,
        "length_scale": length_scale,
    }


def _plain(sa, sb, sampling, off, sp, ms, *, step_s, alpha, min_rotation_deg,
           max_rotation_deg):
    """``(MotionSet, RobustSolution)`` of the plain solve for comparison: offset 0, every
    motion, no rejection (what a solver given the files would do); ``(None, None)`` when
    offset 0 leaves too little overlap."""
    from simcalib.errors import DataError
    from simcalib.estimation.motions import form_motions
    from simcalib.solvers.robust import robust_solve
    try:
        sp0 = synchronised(sa, sb, sampling, _zero()) if off.offset_s != 0 else sp
        ms0 = ms if sp0 is sp else form_motions(
            sp0, ms.policy, paired_by_stamp=sampling.paired_by_stamp,
            index_stamps=_stations_by_index(sampling), step_s=_step(sampling, step_s),
            min_rotation_deg=min_rotation_deg, max_rotation_deg=max_rotation_deg)
        if ms0.n < 2:
            return None, None
        return ms0, robust_solve(ms0.C, ms0.H, "none", alpha=alpha)
    except DataError:
        return None, None


def _per_pass(prior, passes: int):
    """The prior with its weights times ``passes``: motions that pass over the same poses
    several times (one set per span) sum each pose's information that many times in the
    cost, and the prior keeps its weight against the poses (not against the motions)."""
    if prior is None or passes <= 1:
        return prior
    return dataclasses.replace(prior, a=prior.a * passes, b=prior.b * passes)


def _zero():
    from simcalib.estimation.alignment import _as_offset
    return _as_offset(0.0)


def _rot_angle(X1, X2):
    from simcalib.geometry import rotation_error_rad
    return float(rotation_error_rad(X1, X2))
