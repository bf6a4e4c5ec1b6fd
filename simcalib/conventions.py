"""Which reading of two pose files makes them consistent: inverse poses, quaternion order.

Each stream should hold ``T_world_sensor`` (pose of the sensor in a fixed frame). Files often
hold the inverse (``T_sensor_world``, e.g. camera-to-target PnP output) or write quaternions
scalar-first. Both are decided from the data:

* **Quaternion order** — the rotation angle of corresponding relative motions of the two
  streams must agree (``C X = X H`` conjugates rotations, angles are invariant; inversion
  does not change the angles either). Reading the four numbers in the wrong order scrambles
  the angles, so every combination of orders (for quaternion formats) is scored by the
  median ``|angle(C_i) - angle(H_i)|``.
* **Inverse poses** — angles and screw pitches are the same for a stream and its inverse,
  so only a calibration decides: with the right reading one fixed ``X`` satisfies every
  ``C_i X = X H_i``; with one stream inverted none does. Score: median per-motion
  screw-constraint residual after dqopt. Inverting *both* streams is indistinguishable from
  the data (it estimates ``T_world_a_world_b`` instead of ``T_a_b``): stream a is taken as
  written unless ``invert_a`` is given, and the report says so.

:func:`detect_conventions` returns a :class:`ConventionReport` (which reading won, the scores
and how clearly); :func:`apply_conventions` returns the streams read that way.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["ConventionReport", "detect_conventions", "apply_conventions", "CLEAR_RATIO"]

CLEAR_RATIO = 3.0   # runner-up score / winner score above this: "clear"


@dataclass(frozen=True)
class ConventionReport:
    """The reading chosen for two streams.

    ``invert_a`` / ``invert_b``: the file's poses were inverted (file held
    ``T_sensor_world``); ``swap_scalar_a`` / ``_b``: the quaternion numbers were read in the
    other order than the reader's. ``order_scores`` (median angle disagreement, deg, per
    order combination) and ``inverse_scores`` (median screw residual per parity) with
    ``order_ratio`` / ``inverse_ratio`` = runner-up / winner; ``clear`` when every decided
    ratio exceeds :data:`CLEAR_RATIO`. ``forced`` lists what the caller fixed.
    ``offset_s``: the (coarse) clock offset used to pair the motions.
    """
    invert_a: bool
    invert_b: bool
    swap_scalar_a: bool
    swap_scalar_b: bool
    order_scores: dict = field(default_factory=dict)
    inverse_scores: dict = field(default_factory=dict)
    order_ratio: float = math.inf
    inverse_ratio: float = math.inf
    clear: bool = True
    forced: tuple = ()
    offset_s: float = 0.0
    n_motions: int = 0
    message: str = ""


def _swap_options(stream, forced):
    if forced is not None:
        return [bool(forced)]
    if getattr(stream, "quat_order", "matrix") == "matrix":
        return [False]
    return [False, True]


def _apply(stream, swap, invert):
    s = stream
    if swap:
        s = s.with_swapped_scalar()
    if invert:
        s = s.with_inverse()
    return s


def _motions(sa, sb, offset, step_s):
    from simcalib.timesync import make_motions, synchronise
    sp = synchronise(sa, sb, offset)
    return make_motions(sp, step_s=step_s, min_rotation_deg=0.5)[:2]


def _subsample(C, H, max_motions):
    if C.shape[0] > max_motions:
        k = np.linspace(0, C.shape[0] - 1, max_motions).round().astype(int)
        return C[k], H[k]
    return C, H


def _fmt_ratio(r):
    return "inf" if not math.isfinite(r) else f"{r:.1f}x"


def detect_conventions(stream_a, stream_b, *, offset=None, invert_a: bool | None = None,
                       invert_b: bool | None = None, scalar_first_a: bool | None = None,
                       scalar_first_b: bool | None = None, step_s: float | None = None,
                       alpha: float = 1.0, max_motions: int = 600) -> ConventionReport:
    """Decide the reading of two :class:`simcalib.importers.PoseStreamData` from the data.

    ``offset``: clock offset ``t_b - t_a`` (s) or a TimeOffset; None: estimated coarsely
    (angular-speed cross-correlation, convention-free) for each quaternion-order candidate
    (0 for sample-indexed files). ``invert_a``/``invert_b``/``scalar_first_a``/``_b``: force
    a reading (``scalar_first_x`` = swap the reader's quaternion order). ``step_s``: motion
    time step (default 4 periods of the slower stream, at least 0.2 s; consecutive samples
    for sample-indexed files).
    """
    from simcalib.solvers.robust import screw_residuals
    from simcalib.timesync import _coarse_offset, as_time_poses
    import simcalib
    forced = tuple(name for name, v in (("invert_a", invert_a), ("invert_b", invert_b),
                                        ("scalar_first_a", scalar_first_a),
                                        ("scalar_first_b", scalar_first_b)) if v is not None)
    sample_indexed = bool(getattr(stream_a, "synthetic_time", False)
                          or getattr(stream_b, "synthetic_time", False))
    ta, _ = as_time_poses(stream_a, "stream_a")
    tb, _ = as_time_poses(stream_b, "stream_b")
    slow_dt = max(float(np.median(np.diff(ta))), float(np.median(np.diff(tb))))
    if step_s is None:
        step_s = 1.0 if sample_indexed else max(0.2, 4 * slow_dt)
    # 1. quaternion order: angle agreement
    order_scores, offsets = {}, {}
    for sw_a, sw_b in itertools.product(_swap_options(stream_a, scalar_first_a),
                                        _swap_options(stream_b, scalar_first_b)):
        sa, sb = _apply(stream_a, sw_a, False), _apply(stream_b, sw_b, False)
        if offset is not None:
            off = offset
        elif sample_indexed:
            off = 0.0
        else:
            off = _coarse_offset(*as_time_poses(sa), *as_time_poses(sb), None, 0.3)[0]
        C, H = _motions(sa, sb, off, step_s)
        if C.shape[0] < 3:
            continue
        dis = np.abs(rotation_angle_rad(C[:, :3, :3]) - rotation_angle_rad(H[:, :3, :3]))
        order_scores[(sw_a, sw_b)] = float(np.degrees(np.median(dis)))
        offsets[(sw_a, sw_b)] = off
    if not order_scores:
        raise ValueError("too few overlapping motions with rotation to check the conventions "
                         "(do the streams overlap in time, and does the rig rotate?)")
    ranked = sorted(order_scores, key=order_scores.get)
    sw_a, sw_b = ranked[0]
    order_ratio = (order_scores[ranked[1]] / max(order_scores[ranked[0]], 1e-12)
                   if len(ranked) > 1 else math.inf)
    off = offsets[(sw_a, sw_b)]
    # 2. inverse poses: calibration residual per parity
    if invert_a is not None and invert_b is not None:
        parities = [(bool(invert_a), bool(invert_b))]
    else:
        base_a = bool(invert_a) if invert_a is not None else False
        if invert_a is None and invert_b is not None:
            parities = [(False, bool(invert_b)), (True, bool(invert_b))]
        else:
            parities = [(base_a, False), (base_a, True)]
    inverse_scores, n_mot = {}, 0
    for inv_a, inv_b in parities:
        sa, sb = _apply(stream_a, sw_a, inv_a), _apply(stream_b, sw_b, inv_b)
        C, H = _subsample(*_motions(sa, sb, off, step_s), max_motions)
        sol = simcalib.solve(C, H, method="dqopt", alpha=alpha)
        r = screw_residuals(C, H, sol.X, alpha=alpha)
        inverse_scores[(inv_a, inv_b)] = float(np.median(r))
        n_mot = int(C.shape[0])
    ranked_i = sorted(inverse_scores, key=inverse_scores.get)
    inv_a, inv_b = ranked_i[0]
    inverse_ratio = (inverse_scores[ranked_i[1]] / max(inverse_scores[ranked_i[0]], 1e-15)
                     if len(ranked_i) > 1 else math.inf)
    decided = []
    if len(ranked) > 1:
        decided.append(order_ratio)
    if len(ranked_i) > 1:
        decided.append(inverse_ratio)
    clear = all(r > CLEAR_RATIO for r in decided)

    def word(inv, sw, name, order_known):
        parts = [f"stream {name} read as " + ("T_sensor_world, inverted" if inv
                                              else "T_world_sensor (as written)")]
        if order_known:
            parts.append("quaternions " + ("in the other order than the reader's (scalar "
                                           "position swapped)" if sw else "in the reader's order"))
        return ", ".join(parts)
    lines = [word(inv_a, sw_a, "a", len(_swap_options(stream_a, scalar_first_a)) > 1),
             word(inv_b, sw_b, "b", len(_swap_options(stream_b, scalar_first_b)) > 1)]
    if len(ranked) > 1:
        lines.append(f"quaternion order: median |angle(C)-angle(H)| "
                     f"{order_scores[ranked[0]]:.3g} deg vs {order_scores[ranked[1]]:.3g} deg "
                     f"for the next reading ({_fmt_ratio(order_ratio)})")
    if len(ranked_i) > 1:
        lines.append(f"inverse poses: median screw residual {inverse_scores[ranked_i[0]]:.3g} "
                     f"vs {inverse_scores[ranked_i[1]]:.3g} with the other stream inverted "
                     f"({_fmt_ratio(inverse_ratio)})")
    if invert_a is None:
        lines.append("inverting both streams fits equally well (it would estimate "
                     "T_world_a_world_b); stream a taken as written - pass invert_a to force")
    lines.append("reading " + ("won clearly" if clear else
                               f"NOT clear (ratio <= {CLEAR_RATIO}); check the files / force it"))
    if forced:
        lines.append("forced by the caller: " + ", ".join(forced))
    return ConventionReport(inv_a, inv_b, sw_a, sw_b,
                            order_scores={f"{k}": v for k, v in order_scores.items()},
                            inverse_scores={f"{k}": v for k, v in inverse_scores.items()},
                            order_ratio=order_ratio, inverse_ratio=inverse_ratio, clear=clear,
                            forced=forced, offset_s=float(getattr(off, "offset_s", off)),
                            n_motions=n_mot, message="; ".join(lines))


def apply_conventions(stream_a, stream_b, report: ConventionReport):
    """The two streams read as ``report`` decided."""
    return (_apply(stream_a, report.swap_scalar_a, report.invert_a),
            _apply(stream_b, report.swap_scalar_b, report.invert_b))
