"""The scale of stream b's translations against a's, estimated from the motions.

A monocular SLAM or visual-odometry track has no metric scale; a camera whose target size
was entered a few % wrong reads every distance that much too long; a file in other units
is off by 1000 or 100. Then b's translations are ``s`` times what a metric b would read,
and ``C X = X H`` holds only with ``H``'s translations divided by ``s``. With ``u = 1 / s``
the translation equations are linear in ``(t_X, u)`` for a known ``R_X`` (Andreff et al.
2001, "Robot hand-eye calibration using structure-from-motion")::

    (R_C - I) t_X - u R_X t_H = -t_C.

:func:`estimate_scale` alternates the two halves of the problem until they agree: ``X`` by
dqopt on the motions with ``H``'s translations divided by the current ``s`` (``R_X`` from
rotations and translations alike, so motions about one axis - planar, SCARA - still fix
it), then ``(t_X, u)`` by weighted least squares with that ``R_X``; Cauchy weights on the
equations' residuals (and the outlier mask given) keep outlier motions out. It starts from
the pitch invariant of :mod:`simcalib.estimation.units` (``d_H = s d_C`` along each
motion's rotation axis, X-free), which is reported beside it as a cross-check. Its 1-sigma
is a delete-a-group jackknife over contiguous blocks of the synchronised poses (motions
share poses and real errors correlate: the motions' own least-squares covariance would be
far too small). The data cannot tell ``s`` with too few motions or poses, when b barely
translates (pure rotation) or when the motions do not separate the scale from X's
translation (e.g. a vehicle on arcs of one circle); the estimate then says so
(``determined`` False and ``reason``).

:func:`decide` turns an estimate and the ``scale_b`` key into the scale used: ``auto``
keeps 1 unless ``s`` differs from 1 both by more than :data:`TOLERANCE` and by more than
:data:`CLEAR_SIGMAS` sigmas, and explains the translation misfit (:data:`FIT_GAIN`);
``estimate`` always uses the estimate; a number is used as given.
:func:`scale_covariance` gives X's covariance from the scale's 1-sigma (the Jacobian of X
with respect to the scale, by re-solving at ``s (1 +- delta)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

__all__ = ["ScaleEstimate", "ScaleDecision", "estimate_scale", "decide", "scaled_motions",
           "scaled_poses", "scale_covariance", "TOLERANCE", "CLEAR_SIGMAS", "FIT_GAIN",
           "MAX_REL_SIGMA", "MIN_MOTIONS", "MIN_POSES", "MODES", "estimate_for", "decide_for",
           "check_unit_mismatch", "UNIT_RATIOS", "check_scale_b", "scaled_stream"]

#: the ``scale_b`` values that are not a number
MODES = ("auto", "estimate")
#: ``auto`` keeps 1 within this relative distance of it (docs/calibrate.md: a scale error
#: this small moves X by a few mm on a rig of ~0.5 m, and a camera's own depth scale is
#: often off by tenths of a percent - the generated robot_error kind: 0.2..0.8 %)
TOLERANCE = 0.03
#: ... and within this many of the estimate's sigmas
CLEAR_SIGMAS = 5.0
#: ... and only where the scale explains the misfit: the translation misfit at 1 at least
#: this many times that at the estimate (:attr:`ScaleEstimate.fit_gain`; a real scale error
#: of 10 % gives 26..200 on the generated recordings, the metric real sets 1.04..1.77)
FIT_GAIN = 3.0
#: an estimate whose relative 1-sigma exceeds this does not tell the scale
MAX_REL_SIGMA = 0.1
#: fewer motions / synchronised poses than this cannot tell the scale
MIN_MOTIONS = 6
MIN_POSES = 4
#: blocks of the delete-a-group jackknife
BLOCKS = 10
#: the jackknife solves its blocks together, as many a batch as keep the batch's motions
#: (blocks x motions) within this (a long recording's blocks go a few at a time)
BATCH_MOTIONS = 200_000
_ITERATIONS = 60


@dataclass(frozen=True)
class ScaleEstimate:
    """``scale``: b's translations over a's (``d_H = s d_C``; NaN when nothing was fitted);
    ``sigma``: its 1-sigma (jackknife); ``pitch_scale``: the X-free pitch invariant's
    estimate (:func:`simcalib.estimation.units.pitch_scale`, NaN when no motion has pitch);
    ``determined``: the data tell the scale (``reason`` says why not); ``n_motions`` /
    ``n_poses``: what it used; ``iterations``: of the alternation."""
    scale: float
    sigma: float
    pitch_scale: float
    determined: bool
    n_motions: int
    n_poses: int
    reason: str = ""
    iterations: int = 0
    #: the median translation misfit of ``C X = X H`` with X solved at scale 1 over that
    #: with X solved at ``scale`` (b's translations divided by it): how much of the misfit
    #: the scale explains (a true scale error: many times; other systematic errors: little)
    fit_gain: float = math.nan

    def to_dict(self) -> dict:
        fin = lambda x: float(x) if math.isfinite(x) else None  # noqa: E731
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        return d | {k: fin(d[k]) for k in ("scale", "sigma", "pitch_scale")}


@dataclass(frozen=True)
class ScaleDecision:
    """The scale b's translations were divided by (``used``), under ``mode`` (``auto``,
    ``estimate`` or ``given``), and why (``decision``: ``kept`` - 1 used, consistent with
    the data or within the tolerance -, ``not_told`` - the data cannot tell, 1 used -,
    ``rescaled`` - the estimate used -, ``given``); ``sigma_used``: the 1-sigma of ``used``
    that X's covariance holds (0 when kept or given); ``estimate``: the
    :class:`ScaleEstimate` (None when not made); ``check``: the estimate on the rescaled
    data (close to 1 when the rescale worked; None when not rescaled)."""
    mode: str
    used: float
    decision: str
    message: str
    sigma_used: float = 0.0
    estimate: ScaleEstimate | None = None
    check: ScaleEstimate | None = None

    @property
    def rescaled(self) -> bool:
        return self.used != 1.0

    def to_dict(self) -> dict:
        return {"mode": self.mode, "used": self.used, "decision": self.decision,
                "sigma_used": self.sigma_used, "message": self.message,
                "estimate": None if self.estimate is None else self.estimate.to_dict(),
                "check_after_rescale": None if self.check is None else self.check.to_dict(),
                "convention": "b's translations are `used` times a metric b's; X is solved "
                              "with them divided by `used` (X in a's unit)"}


def check_scale_b(value):
    """The ``scale_b`` key checked where it enters: ``auto``, ``estimate`` (returned as
    given) or a finite number > 0 (returned as float); else a ConfigError naming what was
    received and what is allowed."""
    from simcalib.config.checks import check_range
    from simcalib.errors import ConfigError
    if isinstance(value, str) and value in MODES:
        return value
    try:
        return check_range("scale_b", value, lo=0.0, lo_open=True)
    except ConfigError:
        raise ConfigError(key="scale_b", value=value, allowed=(
            "auto, estimate or a finite number > 0 (b's translations over a metric b's: "
            "1000 for b in mm against a in m)")) from None


# ------------------------------------------------------------------------- the model
def scaled_motions(H: np.ndarray, factor: float) -> np.ndarray:
    """``H`` with its translations times ``factor``."""
    out = np.array(H, dtype=np.float64, copy=True)
    out[..., :3, 3] *= factor
    return out


scaled_poses = scaled_motions       # a pose's translation scales alike


def scaled_stream(s, factor: float):
    """The pose stream (PoseStreamData) with its translations times ``factor``."""
    from dataclasses import replace
    return replace(s, T_world_sensor=scaled_poses(s.T_world_sensor, factor))


def _solve_X(C, H, w, alpha) -> np.ndarray:
    from simcalib.solvers.batch_solve import solve_batch
    return np.asarray(solve_batch(C[None], H[None], method="dqopt", alpha=alpha,
                                  weights=w[None]).X[0])


def _linear(C, H, R_X, w) -> tuple[float, np.ndarray, np.ndarray]:
    """``(u, t_X, residual norms)``: weighted least squares of ``(R_C - I) t_X - u R_X t_H
    = -t_C`` (minimum norm along the directions of t_X the motions do not fix)."""
    n = C.shape[0]
    A = np.zeros((n, 3, 4))
    A[:, :, :3] = C[:, :3, :3] - np.eye(3)
    A[:, :, 3] = -(H[:, :3, 3] @ R_X.T)
    b = -C[:, :3, 3]
    sw = np.sqrt(w)[:, None, None]
    x = np.linalg.lstsq((A * sw).reshape(-1, 4), (b[:, :, None] * sw).reshape(-1),
                        rcond=1e-12)[0]
    r = np.linalg.norm(np.einsum("nij,j->ni", A, x) - b, axis=1)
    return float(x[3]), x[:3], r


def _cauchy(r, mask) -> np.ndarray:
    """Cauchy weights of residual norms ``r`` (scale from the median of the masked ones;
    the median norm of a 3-D Gaussian is 1.54 sigma); 0 outside ``mask``."""
    med = float(np.median(r[mask])) if mask.any() else 0.0
    if not med > 0.0:
        return mask.astype(np.float64)
    c = 2.385 * med / 1.54
    return np.where(mask, 1.0 / (1.0 + (r / c) ** 2), 0.0)


def _scale_step(C, Hs, X, w, s) -> tuple[float, np.ndarray, bool]:
    """One alternation step after X (``Hs``: b's motions at the scale ``s``): ``(s_new,
    residual norms, converged)``; ``s_new`` NaN (converged) where the linear fit gives no
    positive ``u``."""
    u, _, r = _linear(C, Hs, X[:3, :3], w)
    if not (math.isfinite(u) and u > 0.0):
        return math.nan, r, True
    s_new = s / u
    return s_new, r, abs(s_new - s) <= 1e-13 * s


def _alternate(C, H, w, s0, alpha, robust=True, iterations=_ITERATIONS):
    """``(s, X, weights, iterations)``: X by dqopt at the current scale, then ``(t_X, u)``
    by weighted least squares with X's rotation, until the scale stops moving; Cauchy
    weights (within ``w > 0``) refreshed from each linear fit when ``robust``."""
    mask = w > 0
    s, wk, k = float(s0), w.copy(), 0
    for k in range(1, iterations + 1):
        Hs = scaled_motions(H, 1.0 / s)
        X = _solve_X(C, Hs, wk, alpha)
        s_new, r, done = _scale_step(C, Hs, X, wk, s)
        if not math.isfinite(s_new):
            return math.nan, X, wk, k
        if robust:
            wk = w * _cauchy(r, mask)
        s = s_new
        if done:
            break
    return s, X, wk, k


def _alternate_blocks(C, H, W, s0, alpha, iterations) -> np.ndarray:
    """``_alternate(C, H, W[g], s0, alpha, robust=False, iterations)[0]`` for every row
    ``g`` of the weights ``W`` (G, N), the same numbers, with one batch of solves per
    iteration over the rows still moving."""
    from simcalib.solvers.batch_solve import solve_batch
    s = np.full(W.shape[0], float(s0))
    moving = np.ones(W.shape[0], dtype=bool)
    for _ in range(iterations):
        rows = np.flatnonzero(moving)
        if rows.size == 0:
            break
        Hs = np.stack([scaled_motions(H, 1.0 / s[g]) for g in rows])
        X = solve_batch(np.broadcast_to(C, Hs.shape), Hs, method="dqopt", alpha=alpha,
                        weights=W[rows]).X
        for Hg, Xg, g in zip(Hs, X, rows):
            s_new, _, done = _scale_step(C, Hg, Xg, W[g], s[g])
            s[g], moving[g] = s_new, not done
    return s


# ---------------------------------------------------------------------- the estimate
def _blocks(n_poses: int, i: np.ndarray, j: np.ndarray) -> list[np.ndarray]:
    """Per block of contiguous synchronised poses: the motions that use none of its poses."""
    g = min(BLOCKS, n_poses)
    edges = np.linspace(0, n_poses, g + 1)
    bi, bj = np.searchsorted(edges, i, side="right") - 1, np.searchsorted(edges, j,
                                                                        side="right") - 1
    return [(bi != k) & (bj != k) for k in range(g)]


def _jackknife_sigma(C, H, w, s, alpha, i, j, n_poses) -> float:
    """The delete-a-group jackknife's 1-sigma of the scale (weights kept from the full
    fit: the blocks move the estimate, not the outlier decisions)."""
    W = [wk for wk in (np.where(keep, w, 0.0) for keep in _blocks(n_poses, i, j))
         if int((wk > 0).sum()) >= MIN_MOTIONS]
    per = max(1, BATCH_MOTIONS // max(C.shape[0], 1))
    est = np.concatenate([_alternate_blocks(C, H, np.asarray(W[b:b + per]), s, alpha, 20)
                          for b in range(0, len(W), per)]) if W else np.zeros(0)
    if est.size < 3 or not np.isfinite(est).all():
        return math.inf
    g = est.size
    return float(math.sqrt((g - 1) / g * np.sum((est - est.mean()) ** 2)))


def estimate_scale(C, H, *, i=None, j=None, n_poses=None, inliers=None,
                   alpha: float = 1.0) -> ScaleEstimate:
    """The scale of b's translations against a's from the motions ``C`` (a), ``H`` (b)
    ``(N, 4, 4)`` (module doc). ``i``, ``j``: each motion's synchronised poses (for the
    jackknife's blocks; default: every motion its own pose pair); ``inliers``: the motions
    to use (default all); ``alpha``: dqopt's translation weight (1/m)."""
    from simcalib.estimation.units import pitch_scale
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    n = C.shape[0]
    i = np.arange(n) if i is None else np.asarray(i)
    j = (np.arange(n) + 1 if j is None else np.asarray(j))
    n_poses = int(max(i.max(initial=-1), j.max(initial=-1)) + 1) if n_poses is None \
        else int(n_poses)
    w = np.ones(n) if inliers is None else np.asarray(inliers, dtype=np.float64)
    used = w > 0
    sp = pitch_scale(C[used], H[used])[0] if used.any() else math.nan
    nm = int(used.sum())
    poses = int(np.unique(np.concatenate([i[used], j[used]])).size)
    if nm < MIN_MOTIONS or poses < MIN_POSES:
        return ScaleEstimate(math.nan, math.inf, sp, False, nm, poses,
                             f"{nm} motions between {poses} poses are too few to tell it "
                             f"(at least {MIN_MOTIONS} motions and {MIN_POSES} poses)")
    why = _no_translation(C[used], H[used])
    if why:
        return ScaleEstimate(math.nan, math.inf, sp, False, nm, poses, why)
    s0 = sp if math.isfinite(sp) and sp > 0.0 else 1.0
    s, _, wk, k = _alternate(C, H, w, s0, alpha)
    if not (math.isfinite(s) and s > 0.0):
        return ScaleEstimate(s, math.inf, sp, False, nm, poses, "the fit gives no positive "
                             "scale: the motions do not separate it from X's translation", k)
    sig = _jackknife_sigma(C, H, wk, s, alpha, i, j, n_poses)
    ok = math.isfinite(sig) and sig <= MAX_REL_SIGMA * s
    gain = _misfit(C, H, wk, 1.0, alpha) / max(_misfit(C, H, wk, s, alpha), 1e-300)
    return ScaleEstimate(s, sig, sp, ok, nm, poses, "" if ok else (
        f"its 1-sigma is {100 * sig / s:.3g} % of it (> {100 * MAX_REL_SIGMA:g} %): the "
        "motions do not separate b's scale from X's translation (e.g. arcs about one centre)"
        ), k, float(gain))


def _misfit(C, H, w, s, alpha) -> float:
    """The weighted median translation misfit of ``C X = X H`` (``H``'s translations
    divided by ``s``, X by dqopt on them)."""
    Hs = scaled_motions(H, 1.0 / s)
    X = _solve_X(C, Hs, w, alpha)
    r = np.linalg.norm(C[:, :3, :3] @ X[:3, 3] + C[:, :3, 3] - Hs[:, :3, 3] @ X[:3, :3].T
                       - X[:3, 3], axis=1)
    m = w > 0
    return float(np.median(r[m])) if m.any() else math.nan


def _no_translation(C, H) -> str:
    """Why the motions cannot tell a scale when b barely translates (a rig that only
    turns about its own centre): '' otherwise."""
    tc = np.linalg.norm(C[:, :3, 3], axis=1)
    th = np.linalg.norm(H[:, :3, 3], axis=1)
    if float(np.median(th)) > 0.0 and float(np.median(tc)) > 0.0:
        return ""
    return ("stream b (or a) does not translate between its poses (median translation of "
            f"the motions {float(np.median(th)):.3g} (b), {float(np.median(tc)):.3g} (a)): a "
            "pure rotation shows no scale")


# ----------------------------------------------------------------------- the decision
def decide(mode, estimate: ScaleEstimate | None) -> ScaleDecision:
    """The scale used for ``mode`` (``auto``, ``estimate`` or a number) and ``estimate``.
    ``estimate`` mode with an estimate that does not tell the scale raises DataError."""
    if mode not in MODES:
        return ScaleDecision("given", float(mode), "given", f"b's translations divided by "
                             f"{float(mode):g} (scale_b given)", 0.0, estimate)
    e = estimate
    if e is None or not e.determined:
        why = "no motions" if e is None else e.reason
        if mode == "estimate":
            from simcalib.errors import DataError
            raise DataError(f"scale_b=estimate: the data cannot tell the scale of stream b's "
                            f"translations ({why}); give scale_b=<number> (b's translations over "
                            "a metric b's: 1000 for b in mm against a in m) or scale_b=auto "
                            "(1 unless the data tell otherwise)")
        return ScaleDecision(mode, 1.0, "not_told", f"b's scale not told by the data ({why}):"
                             " 1 used", 0.0, e)
    dev = abs(e.scale - 1.0)
    words = (f"b's translations read {e.scale:.4g} +- {e.sigma:.2g} times a's (pitch "
             f"invariant {_g(e.pitch_scale)})")
    if mode == "estimate":
        return ScaleDecision(mode, e.scale, "rescaled", words + "; divided by it "
                             "(scale_b=estimate)", e.sigma, e)
    if dev <= TOLERANCE or dev <= CLEAR_SIGMAS * e.sigma or not e.fit_gain >= FIT_GAIN:
        return ScaleDecision(mode, 1.0, "kept", words + (
            ": consistent with 1, kept" if dev <= CLEAR_SIGMAS * e.sigma else
            f": within the {100 * TOLERANCE:g} % tolerance, 1 kept (scale_b=estimate uses "
            "it)" if dev <= TOLERANCE else
            f", but that scale explains little of the translation misfit (x{e.fit_gain:.3g} "
            f"< {FIT_GAIN:g}): other systematic errors, not a scale; 1 kept (scale_b=estimate"
            " uses it)"), 0.0, e)
    return ScaleDecision(mode, e.scale, "rescaled", words + f": {dev / e.sigma:.3g} sigma and "
                         f"{100 * dev:.3g} % from 1, explaining the translation misfit (x"
                         f"{e.fit_gain:.3g}), so X is solved with b's translations "
                         "divided by it and its sigma includes the scale's; " + CAUSES,
                         e.sigma, e)


#: what makes b's scale differ from a's
CAUSES = ("likely causes: a monocular SLAM / visual-odometry track (no metric scale), a "
          "wrong target or marker size in the detector, or other length units; scale_b=1 "
          "forces metres as written, scale_b=<number> a known scale")


def _g(x) -> str:
    return f"{x:.4g}" if math.isfinite(x) else "not told"


def scale_covariance(C, H, w, sigma_rel: float, alpha: float = 1.0,
                     delta: float = 1e-3) -> np.ndarray:
    """``(6, 6)``: X's covariance from a relative 1-sigma ``sigma_rel`` of the scale of
    ``H``'s translations (already divided by the scale used): ``J J^T sigma_rel^2`` with
    ``J`` the change of X (``pose_error`` coordinates, frame a) per relative change of the
    scale, by dqopt at ``1 -+ delta`` (weights ``w``)."""
    from simcalib.solvers.diagnostics.inputs import pose_error
    C = np.asarray(C, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    Xp = _solve_X(C, scaled_motions(H, 1.0 / (1.0 + delta)), w, alpha)
    Xm = _solve_X(C, scaled_motions(H, 1.0 / (1.0 - delta)), w, alpha)
    J = pose_error(Xp, Xm) / (2.0 * delta)
    return np.outer(J, J) * sigma_rel ** 2


def estimate_for(ms, synced, inliers, alpha: float = 1.0) -> ScaleEstimate:
    """:func:`estimate_scale` on a :class:`~simcalib.estimation.motions.MotionSet`'s
    ``inliers`` between the poses of ``synced``."""
    return estimate_scale(ms.C, ms.H, i=ms.i, j=ms.j, n_poses=synced.n, inliers=inliers,
                          alpha=alpha)


def decide_for(ms, synced, inliers, scale_b, alpha: float = 1.0,
               hint: str = "") -> ScaleDecision:
    """The :class:`ScaleDecision` of ``scale_b`` on the motions; a given scale's estimate
    is that of the data as rescaled (``check``: close to 1 when the scale given is
    right). With ``auto``, a unit mismatch is refused (:func:`check_unit_mismatch`;
    ``hint``: what its message offers)."""
    import dataclasses
    e = estimate_for(ms, synced, inliers, alpha)
    if scale_b not in MODES:
        return dataclasses.replace(decide(float(scale_b), None), check=e)
    if scale_b == "auto":
        check_unit_mismatch(e, ms.C, ms.H, hint)
    return decide(scale_b, e)


#: b's scale against a's when the files hold other length units: (ratio, the units)
UNIT_RATIOS = tuple((r, f"b in {ub} against a in {ua}") for r, ub, ua in (
    (1e3, "mm", "m"), (1e2, "cm", "m"), (1e1, "dm", "m"), (1e-3, "m", "mm"),
    (1e-2, "m", "cm"), (1e-1, "m", "dm"), (1.0 / 0.3048, "feet", "m"),
    (0.3048, "m", "feet"), (1.0 / 0.0254, "inches", "m"), (0.0254, "m", "inches"),
    (25.4, "mm", "inches"), (1.0 / 25.4, "inches", "mm")))
#: a unit ratio is matched within this relative distance (beyond CLEAR_SIGMAS sigmas)
UNIT_MATCH = 0.003


def check_unit_mismatch(e: ScaleEstimate, C, H, hint: str = "") -> None:
    """DataError when b's scale is a unit mismatch: beyond
    :data:`simcalib.estimation.units.MAX_SCALE_RATIO` from 1 and at a ratio of length units
    (:data:`UNIT_RATIOS`, within :data:`UNIT_MATCH` or :data:`CLEAR_SIGMAS` sigmas). A far
    scale at no unit ratio (a monocular SLAM track) is left to :func:`decide`; where the
    estimate does not tell the scale, the pitch invariant's check decides
    (:func:`simcalib.estimation.units.check_translation_units`)."""
    from simcalib.estimation.units import MAX_SCALE_RATIO, check_translation_units
    if not e.determined:
        if C.shape[0]:
            check_translation_units(C, H, **({"hint": hint} if hint else {}))
        return
    if abs(math.log(e.scale)) <= math.log(MAX_SCALE_RATIO):
        return
    for ratio, what in UNIT_RATIOS:
        if abs(e.scale / ratio - 1.0) <= max(UNIT_MATCH, CLEAR_SIGMAS * e.sigma / e.scale):
            from simcalib.errors import DataError
            raise DataError(
                f"the streams measure translation in different units: stream b moves "
                f"{e.scale:.5g} +- {e.sigma:.2g} times as far as stream a (the motions' "
                f"linear fit over {e.n_motions} motions; the pitch invariant "
                f"{_g(e.pitch_scale)}), {ratio:.5g} within its uncertainty: {what}? "
                + (hint or "write both in metres"))
