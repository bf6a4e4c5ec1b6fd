"""Which reading of two pose files makes them consistent: inverse poses, quaternion order.

Each stream should hold ``T_world_sensor`` (pose of the sensor in a fixed frame). Files often
hold the inverse (``T_sensor_world``, e.g. camera-to-target PnP output) or write quaternions
scalar-first. Both are decided from the data:

Neither can be decided from rotation angles alone: the angle between two poses,
``2 acos |q_i . q_j|``, is the same for a pose stream and its inverse and for any order of the
four quaternion numbers (a permutation keeps the dot product), so the angular speeds and the
motion angles agree under every reading. What differs is whether ONE fixed ``X`` satisfies
every ``C_i X = X H_i``: for a wrong reading the motions of one stream are conjugated by a
varying pose (inversion) or mapped by a non-homomorphic permutation (quaternion order), and
no ``X`` fits. So every candidate reading is scored by the median per-motion screw residual
after dqopt, on motions between random pairs of synchronised instants (large motions; the
small consecutive ones cannot separate the readings). Inverting *both* streams is
indistinguishable from the data (it estimates ``T_world_a_world_b`` instead of ``T_a_b``):
stream a is taken as written unless ``invert_a`` is given, and the report says so.

:func:`detect_conventions` returns a :class:`ConventionReport` (which reading won, the scores
and how clearly); :func:`apply_conventions` returns the streams read that way.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["ConventionReport", "detect_conventions", "apply_conventions", "CLEAR_RATIO",
           "MIRROR_RATIO", "PITCH_AGREEMENT", "mirror_ratio", "mirrored_fit", "mirror_sentence",
           "mirror_untold_sentence", "mirrored", "pitch_agreement"]

CLEAR_RATIO = 3.0   # runner-up score / winner score above this: "clear"
#: the best score with b as read / mirrored (:func:`mirror_ratio`) above this: b is taken as
#: mirrored (a left-handed file). ``python -m simcalib.tools.mirror_margin`` (20 seeds of 20
#: generated kinds, 18 real sets): files as written at most 1.04 (planar: cannot tell),
#: 0.83 where the motion tells; mirrored files 5.1 and more on the 6-DoF kinds, 1.4-6.7 on
#: the noisy tag sets (docs/mirror-margin.md).
MIRROR_RATIO = 4.0
#: :func:`pitch_agreement` above this: b's pitches follow a's, the mirrored readings are not
#: scored. Measured alike: mirrored files at most 3.6 (a wrong quaternion order chosen),
#: files as written 1.8 and more (most 20 and more)
PITCH_AGREEMENT = 10.0


@dataclass(frozen=True)
class ConventionReport:
    """The reading chosen for two streams.

    ``invert_a`` / ``invert_b``: the file's poses were inverted (the file held
    ``T_sensor_world``); ``swap_scalar_a`` / ``_b``: the quaternion numbers were read in the
    other order than the reader's (scalar-first <-> scalar-last). ``scores``: median
    per-motion screw residual (dqopt) of every candidate reading; ``ratio``: runner-up score
    / winner score and ``runner_up`` its description; ``clear`` when ``ratio`` exceeds
    :data:`CLEAR_RATIO`. ``forced`` lists what the caller fixed; ``offset_s`` the clock offset
    used to pair the poses; ``n_motions`` the motions scored per candidate; ``runner_up_X``
    the X the runner-up reading gives (how much the reading matters when it is not clear).
    """
    invert_a: bool
    invert_b: bool
    swap_scalar_a: bool
    swap_scalar_b: bool
    scores: dict = field(default_factory=dict)
    ratio: float = math.inf
    runner_up: str = ""
    clear: bool = True
    forced: tuple = ()
    offset_s: float = 0.0
    n_motions: int = 0
    message: str = ""
    #: the runner-up reading's X (RANSAC + dqopt on the scored motions; None: no runner-up)
    runner_up_X: np.ndarray | None = field(default=None, repr=False)
    #: b read mirrored (:func:`mirrored`: a left-handed file, z negated) in every candidate
    mirror_b: bool = False
    #: the best score with b as read over the best with b mirrored (:func:`mirror_ratio`);
    #: NaN: not checked (forced; or b's pitches follow a's: :func:`pitch_agreement`)
    mirror_ratio: float = math.nan
    #: the best mirrored reading's X where the data do not tell the handedness
    #: (:attr:`mirror_told` false; None otherwise)
    mirror_X: np.ndarray | None = field(default=None, repr=False)

    @property
    def mirror_told(self) -> bool:
        """Whether the data tell b's handedness: not checked (b's pitches follow a's, or
        forced), or one side won by more than :data:`MIRROR_RATIO`."""
        r = self.mirror_ratio
        return not (math.isfinite(r) and 1.0 / MIRROR_RATIO <= r <= MIRROR_RATIO)


def _swap_options(stream, forced):
    if forced is not None:
        return [bool(forced)]
    if getattr(stream, "quat_order", "matrix") == "matrix":
        return [False]
    return [False, True]


def _apply(stream, swap, invert, mirror=False):
    s = stream
    if swap:
        s = s.with_swapped_scalar()
    if invert:
        s = s.with_inverse()
    if mirror:          # last: the mirror is of the poses (after the quaternion order)
        s = mirrored(s)
    return s


def mirrored(stream):
    """The stream read in the mirror image of its frames (a LEFT-HANDED file, e.g. Unity,
    Unreal, DirectX trackers): ``T -> M T M`` with ``M = diag(1, 1, -1, 1)``, i.e.
    positions ``z -> -z`` and quaternions ``(x, y, z, w) -> (-x, -y, z, w)``. A mirror
    about x or y differs from it by a proper rotation (which X absorbs): one is enough."""
    from dataclasses import replace
    T = np.array(stream.T_world_sensor, dtype=np.float64)
    T[:, 2, :] *= -1.0
    T[:, :, 2] *= -1.0
    return replace(stream, T_world_sensor=T)


def _motions(sa, sb, offset, n_pairs, rng, sampling=None, signal="rotation"):
    """Motions between random pairs of synchronised instants (large motions separate the
    readings best; consecutive steps are too small to tell them apart) that turn by more
    than 1 deg (``signal`` ``translation``, a rig that does not turn: that translate by a
    tenth of the median motion or more). ``sampling``: a
    :class:`simcalib.estimation.sampling.Sampling` that pairs by stamp."""
    from simcalib.geometry import invert_transform
    from simcalib.estimation.alignment import synchronise
    if sampling is not None and sampling.paired_by_stamp:
        from simcalib.estimation.sampling import pair_by_stamp
        sp = pair_by_stamp(sa, sb, sampling, float(getattr(offset, "offset_s", offset)))
    else:
        sp = synchronise(sa, sb, offset)
    n = sp.n
    if n < 3:
        return np.zeros((0, 4, 4)), np.zeros((0, 4, 4))
    i = rng.integers(0, n, size=n_pairs)
    j = rng.integers(0, n, size=n_pairs)
    keep = i != j
    if sp.world is not None:            # never across a jump of a world frame
        keep &= sp.world[i] == sp.world[j]
    i, j = i[keep], j[keep]
    C = invert_transform(sp.T_a[i]) @ sp.T_a[j]
    H = invert_transform(sp.T_b[i]) @ sp.T_b[j]
    if signal == "translation":
        from simcalib.estimation.stillness import translates
        keep = translates(0.5 * (np.linalg.norm(C[:, :3, 3], axis=1)
                                 + np.linalg.norm(H[:, :3, 3], axis=1)))
    else:
        ang = 0.5 * (rotation_angle_rad(C[:, :3, :3]) + rotation_angle_rad(H[:, :3, :3]))
        keep = ang > np.radians(1.0)
    return C[keep], H[keep]


def _fmt_ratio(r):
    return "inf" if not math.isfinite(r) else f"{r:.1f}x"


def _label(sw, inv, name, has_order, mirror=False):
    s = f"{name}: " + ("inverted (file holds T_sensor_world)" if inv else "as written")
    if has_order:
        s += ", quaternion order " + ("swapped" if sw else "as read")
    if mirror:
        s += ", MIRRORED (left-handed file: z negated)"
    return s


def _ranked(scores: dict, written: tuple) -> tuple:
    """``(ranked, ratio, clear, fallback)``: the readings best first, the runner-up's score
    over the best's and whether that is clear (> :data:`CLEAR_RATIO`); where it is not, the
    reading closest to the files as ``written`` goes first (``fallback``: "written" or
    "closest"; None when the data told)."""
    ranked = sorted(scores, key=scores.get)
    ratio = scores[ranked[1]] / max(scores[ranked[0]], 1e-15) if len(ranked) > 1 \
        else math.inf
    clear = ratio > CLEAR_RATIO
    fallback = _closest_to_written(ranked, scores, written) if not clear else None
    if fallback is not None:    # the data cannot tell: the files as written, and said so
        ranked.remove(fallback)
        ranked.insert(0, fallback)
        fallback = "written" if fallback == written else "closest"
    return ranked, ratio, clear, fallback


def detect_conventions(stream_a, stream_b, *, offset=None, invert_a: bool | None = None,
                       invert_b: bool | None = None, scalar_first_a: bool | None = None,
                       scalar_first_b: bool | None = None, alpha: float = 1.0,
                       n_pairs: int = 400, seed: int = 0, sampling=None,
                       signal: str = "auto", mirror_b: bool = False) -> ConventionReport:
    """Decide the reading of two :class:`simcalib.importers.PoseStreamData` from the data.

    Every candidate reading (quaternion order of each quaternion-format stream x inversion
    of b relative to a) is scored by the median per-motion screw residual of the RANSAC +
    dqopt estimate (robust to outlier poses) on
    ``n_pairs`` motions between random pairs of synchronised instants (seeded by ``seed``).
    ``offset``: clock offset ``t_b - t_a`` (s) or a TimeOffset; None: the coarse
    angular-speed cross-correlation estimate (it is the same for every reading: relative
    rotation angles do not depend on inversion or quaternion order), 0 for sample-indexed
    files. ``invert_a``/``invert_b``/``scalar_first_a``/``_b``: force a reading
    (``scalar_first_x=True`` = read the quaternion numbers in the other order than the
    reader did). ``sampling``: how the streams are paired
    (:func:`simcalib.estimation.sampling.classify_sampling`; stamp-paired streams are never
    interpolated); None: interpolated at the offset. ``signal``: ``rotation`` or
    ``translation`` (a rig that does not turn: the motions scored are those that
    translate, and the offset's correlation is of translation speeds); ``auto``: rotation
    unless neither stream turns. Without rotation the data tell less: the quaternion order
    never (a constant misread orientation only rotates every ``t_C`` alike, which X's
    rotation absorbs), an inverted stream only when the translations span 3-D (in a plane
    ``-t`` is ``t`` turned by 180 deg about its normal); the ratio says so (about 1).
    ``mirror_b``: every candidate reads b mirrored (:func:`mirrored`; whether it is, is
    decided apart: :func:`mirror_ratio`).
    """
    from simcalib.estimation.speeds import checked_signal
    signal = checked_signal(signal, stream_a, stream_b)
    forced = tuple(name for name, v in (("invert_a", invert_a), ("invert_b", invert_b),
                                        ("scalar_first_a", scalar_first_a),
                                        ("scalar_first_b", scalar_first_b)) if v is not None)
    off = _reading_offset(stream_a, stream_b, offset, sampling, signal)
    parities = _parities(invert_a, invert_b)
    has_order = (len(_swap_options(stream_a, scalar_first_a)) > 1,
                 len(_swap_options(stream_b, scalar_first_b)) > 1)
    scores, n_mot, xs = _score_readings(stream_a, stream_b, off, parities,
                                    (_swap_options(stream_a, scalar_first_a),
                                     _swap_options(stream_b, scalar_first_b)),
                                    n_pairs=n_pairs, alpha=alpha, seed=seed, sampling=sampling,
                                    signal=signal, mirror_b=mirror_b)
    if not scores:
        raise _no_overlap(stream_a, stream_b, off)
    ranked, ratio, clear, fallback = _ranked(scores, (False, False) + parities[0])
    sw_a, sw_b, inv_a, inv_b = ranked[0]

    def desc(k):
        return (_label(k[0], k[2], "a", has_order[0]) + "; "
                + _label(k[1], k[3], "b", has_order[1], mirror_b))
    lines = _reading_lines(desc, scores, ranked, ratio, clear, fallback, invert_a, invert_b,
                           forced)
    return ConventionReport(inv_a, inv_b, sw_a, sw_b,
                            scores={desc(k): v for k, v in scores.items()}, ratio=ratio,
                            runner_up=desc(ranked[1]) if len(ranked) > 1 else "",
                            clear=clear, forced=forced,
                            offset_s=float(getattr(off, "offset_s", off)), n_motions=n_mot,
                            message="; ".join(lines),
                            runner_up_X=xs[ranked[1]] if len(ranked) > 1 else None,
                            mirror_b=bool(mirror_b))


def mirror_ratio(stream_a, stream_b, report: ConventionReport, **kw) -> float:
    """:func:`mirrored_fit`'s ratio."""
    return mirrored_fit(stream_a, stream_b, report, **kw)[0]


def mirrored_fit(stream_a, stream_b, report: ConventionReport, *, offset,
                 invert_a: bool | None = None, invert_b: bool | None = None,
                 scalar_first_a: bool | None = None, scalar_first_b: bool | None = None,
                 alpha: float = 1.0, n_pairs: int = 400, seed: int = 0, sampling=None,
                 signal: str = "rotation") -> tuple[float, np.ndarray | None]:
    """``(ratio, X)``: how much better b fits mirrored (:func:`mirrored`, a left-handed
    file): the best score of ``report`` (b as read; every candidate reading) over the best
    score of the same candidates with b mirrored, on the same random pairs of instants at ``offset``
    (the forcing keys as :func:`detect_conventions`'s). Decided apart from the other
    choices of the reading, but over all of them (a mirrored b read as written can make a
    wrong quaternion order fit best). The mirror shows only in the translations along the
    rotation axes (it negates each motion's pitch; the rotations are the old ones turned
    by 180 deg, which X absorbs), so a motion whose rotations share one axis with no
    translation along it (planar) cannot tell: the ratio is ~1 there. ``X``: the best
    mirrored reading's (RANSAC + dqopt on the scored motions). NaN, None: too few
    motions."""
    scores, _, xs = _score_readings(stream_a, stream_b, offset, _parities(invert_a, invert_b),
                                   (_swap_options(stream_a, scalar_first_a),
                                    _swap_options(stream_b, scalar_first_b)),
                                   n_pairs=n_pairs, alpha=alpha, seed=seed, sampling=sampling,
                                   signal=signal, mirror_b=True)
    if not scores or not report.scores:
        return math.nan, None
    best = min(scores, key=scores.get)
    return min(report.scores.values()) / max(scores[best], 1e-15), xs[best]


def pitch_agreement(stream_a, stream_b, report: ConventionReport, *, offset,
                    n_pairs: int = 400, seed: int = 0, sampling=None,
                    signal: str = "rotation") -> float:
    """``median |d_C + d_H| / median |d_C - d_H|`` over the pitches (translation along the
    rotation axis, :mod:`simcalib.estimation.units`) of the motions ``report``'s reading
    gives: a cheap first look at the handedness (a mirrored b negates every pitch, the
    reading's other choices keep it). Above :data:`PITCH_AGREEMENT`: b's pitches follow
    a's, b is not mirrored; else :func:`mirror_ratio` decides. NaN: too few motions."""
    from simcalib.estimation.units import _pitches
    sa, sb = apply_conventions(stream_a, stream_b, report)
    C, H = _motions(sa, sb, offset, n_pairs, np.random.default_rng(seed), sampling, signal)
    d_c, d_h = _pitches(C, H) if C.shape[0] >= 3 else (np.zeros(0), np.zeros(0))
    if d_c.size < 3:
        return math.nan
    return float(np.median(np.abs(d_c + d_h)) / max(np.median(np.abs(d_c - d_h)), 1e-15))


def pitch_magnitudes_scale(stream_a, stream_b, *, offset, n_pairs: int = 400, seed: int = 0,
                           sampling=None, signal: str = "rotation") -> tuple[float, float]:
    """``(s, spread)``: b's length scale against a's from the magnitudes of the motions'
    pitches at ``offset`` (:mod:`simcalib.estimation.units`; the magnitude is the same for
    a motion and its inverse or conjugate, so any reading of the files but the quaternion
    order gives it), the weighted median of ``|d_H| / |d_C|``, and ``spread`` the median
    ``|log(|d_H| / (s |d_C|))|`` (small where the offset pairs the motions right). NaN for
    fewer than 5 motions with pitch."""
    from simcalib.estimation.units import _pitches, _weighted_median
    C, H = _motions(stream_a, stream_b, offset, n_pairs, np.random.default_rng(seed),
                    sampling, signal)
    d_c, d_h = (np.abs(d) for d in _pitches(C, H)) if C.shape[0] >= 3 else ((), ())
    use = (np.asarray(d_c) > 0.0) & (np.asarray(d_h) > 0.0)
    if np.count_nonzero(use) < 5:
        return math.nan, math.nan
    ratio = d_h[use] / d_c[use]
    s = _weighted_median(ratio, d_c[use] ** 2)
    return float(s), float(np.median(np.abs(np.log(ratio / s))))


def mirror_sentence(ratio: float) -> str:
    """What a mirrored b means for the user (the reading's message and the warnings)."""
    return (f"stream b is MIRRORED against a: its poses fit {ratio:.3g}x better with z "
            "negated (positions z -> -z, quaternions (-qx, -qy, qz, qw)) than as written, "
            "where no rotation relates them: one file is left-handed (Unity, Unreal, "
            "DirectX-based trackers); calibrated with b read so, X = T_a_b' with b' = b's "
            "frame with its z axis negated (if a is the left-handed one, M X M with "
            "M = diag(1, 1, -1) is T_a'_b between a's frame mirrored so and b's); pass "
            "mirror_b=false to take b as written")


def mirror_untold_sentence(ratio: float) -> str:
    """The reading's words where the data do not tell b's handedness."""
    side = (f"b as written fits {1.0 / ratio:.3g}x better than mirrored" if ratio < 1.0
            else f"b mirrored fits {ratio:.3g}x better than as written")
    return (f"whether b is mirrored (a left-handed file) is not told by these data: {side} "
            f"(a side is taken only beyond {MIRROR_RATIO:g}x; motions that turn about one "
            "axis with no translation along it, as planar ones, cannot tell at all); b taken "
            "as written, pass mirror_b=true if its file is left-handed")


def _score_readings(stream_a, stream_b, off, parities, swaps, *, n_pairs, alpha, seed,
                    sampling, signal="rotation", mirror_b=False) -> tuple[dict, int, dict]:
    """``({(swap_a, swap_b, invert_a, invert_b): score}, motions scored, {reading: X})``:
    every reading's :func:`_reading_score` on the same random pairs of instants (readings
    with fewer than 3 motions left out; ``mirror_b``: b read mirrored)."""
    scores, n_mot, xs = {}, 0, {}
    for sw_a, sw_b in itertools.product(*swaps):
        for inv_a, inv_b in parities:
            sa, sb = _apply(stream_a, sw_a, inv_a), _apply(stream_b, sw_b, inv_b, mirror_b)
            C, H = _motions(sa, sb, off, n_pairs, np.random.default_rng(seed), sampling,
                            signal)
            if C.shape[0] < 3:
                continue
            key = (sw_a, sw_b, inv_a, inv_b)
            scores[key], xs[key] = _reading_score(C, H, alpha, seed)
            n_mot = int(C.shape[0])
    return scores, n_mot, xs


def _no_overlap(stream_a, stream_b, off):
    """The DataError for streams without enough overlapping, rotating poses at ``off`` (a
    given TimeOffset, or seconds): both streams' spans on a's clock."""
    from simcalib.errors import DataError
    ta, tb = stream_a.timestamps_s, stream_b.timestamps_s
    off = float(getattr(off, "offset_s", off))
    return DataError(
        "too few overlapping poses with rotation to check the conventions: with the "
        f"offset t_b - t_a = {off:.6g} s, a spans {ta[0]:.6g}..{ta[-1]:.6g} s and b "
        f"{tb[0] - off:.6g}..{tb[-1] - off:.6g} s ({ta.size} and {tb.size} poses); do the "
        "stamps share a unit and a clock, and does the rig rotate?")


def _reading_offset(stream_a, stream_b, offset, sampling, signal="rotation"):
    """The offset at which the readings are compared: the given one; 0 for sample-indexed
    or stamp-paired files; else the coarse angular-speed correlation's (the same for every
    reading)."""
    from simcalib.estimation.alignment import _coarse_offset
    from simcalib.estimation.speeds import as_time_poses
    if offset is not None:
        return offset
    if (getattr(stream_a, "synthetic_time", False) or getattr(stream_b, "synthetic_time", False)
            or (sampling is not None and sampling.paired_by_stamp)):
        return 0.0
    return _coarse_offset(*as_time_poses(stream_a, "stream_a"),
                          *as_time_poses(stream_b, "stream_b"), None, 0.3,
                          signal=signal)[0]


def _parities(invert_a, invert_b) -> list[tuple[bool, bool]]:
    """The (invert a, invert b) pairs to compare: only the relative inversion is
    identifiable, so a stays as written (or as forced) unless only b is forced."""
    if invert_a is not None and invert_b is not None:
        return [(bool(invert_a), bool(invert_b))]
    if invert_b is not None:
        return [(False, bool(invert_b)), (True, bool(invert_b))]
    base_a = bool(invert_a) if invert_a is not None else False
    return [(base_a, False), (base_a, True)]


def _reading_score(C, H, alpha: float, seed: int) -> tuple[float, np.ndarray]:
    """``(median screw residual, X)`` of a robust fit (outlier poses must not decide the
    reading): RANSAC + dqopt, plain dqopt when RANSAC cannot run."""
    from simcalib.solvers.api import solve
    from simcalib.solvers.robust import ransac, screw_residuals
    try:
        rob = ransac(C, H, alpha=alpha, rng=np.random.default_rng(seed), max_iterations=256)
    except (ValueError, RuntimeError):   # RANSAC: too few motions / no consensus
        X = solve(C, H, method="dqopt", alpha=alpha).X
        return float(np.median(screw_residuals(C, H, X, alpha=alpha))), X
    # RANSAC's residuals are screw_residuals(C, H, X, alpha) of its X, to the bit (the same
    # motion matrices and X): not computed again
    return float(np.median(rob.residuals)), rob.X


def _closest_to_written(ranked, scores, written):
    """Of the readings that fit within :data:`CLEAR_RATIO` of the best (the data cannot
    tell them apart), the one that changes the files least (fewest inversions and swapped
    orders; e.g. a rig that only translates cannot tell any quaternion order); None when
    that is the best already."""
    near = [k for k in ranked if scores[k] <= CLEAR_RATIO * scores[ranked[0]]]
    closest = min(near, key=lambda k: (sum(x != y for x, y in zip(k, written)), scores[k]))
    return None if closest == ranked[0] else closest


def _reading_lines(desc, scores, ranked, ratio, clear, fallback, invert_a, invert_b,
                   forced) -> list[str]:
    """The reading's message, sentence by sentence."""
    best = ranked[0]
    lines = [f"reading used: {desc(best)}"]
    if fallback == "written":
        lines.append("no reading fits clearly better than the files as written (within "
                     f"{CLEAR_RATIO:g}x): they are taken as written")
    elif fallback == "closest":
        lines.append("no reading fits clearly better than this one, the closest to the "
                     f"files as written of those within {CLEAR_RATIO:g}x of the best: it is "
                     "used")
    if len(ranked) > 1:
        lines.append(f"median screw residual {scores[best]:.3g} vs {scores[ranked[1]]:.3g} "
                     f"for the runner-up ({desc(ranked[1])}): {_fmt_ratio(ratio)}, "
                     + ("clear" if clear else f"NOT clear (<= {CLEAR_RATIO}x): check the "
                        "files or force the reading"))
    if invert_a is None and invert_b is None:
        lines.append("inverting both streams fits equally well (it would estimate "
                     "T_world_a_world_b): stream a taken as written, pass invert_a to force")
    elif invert_a is None:
        lines.append("b's inversion was forced, so a's reading was chosen relative to it "
                     "(only the relative reading is identifiable)")
    if forced:
        lines.append("forced by the caller: " + ", ".join(forced))
    return lines


def apply_conventions(stream_a, stream_b, report: ConventionReport):
    """The two streams read as ``report`` decided."""
    return (_apply(stream_a, report.swap_scalar_a, report.invert_a),
            _apply(stream_b, report.swap_scalar_b, report.invert_b, report.mirror_b))
