"""Camera pose from ArUco detections by PnP: all visible markers of the map jointly.

:func:`estimate_camera_pose` scores both IPPE_SQUARE solutions of the largest markers and
one SQPnP over all corners robustly, refines the best on its inlier markers, drops outlier
markers, tests the best distinct rival for ambiguity and gates on the reprojection error;
a frame without a usable pose gets a reason (:data:`DROP_REASONS`), never a pose. The
detections come from :mod:`simcalib.targets.markers` (undistorted with
:func:`undistort_points` when the camera has lens distortion).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import invert_transform
from simcalib.targets.markers import Detections, MarkerField, marker_corners_local

__all__ = ["CameraPoseEstimate", "DROP_REASONS", "PnPSettings", "estimate_camera_pose",
           "transform_from_rvec_tvec", "undistort_points"]

#: Why a frame yields no camera pose (keys of ``PoseStream.drop_reasons``).
DROP_REASONS = {
    "no_markers": "no marker detected in the image",
    "no_known_markers": "markers detected, but none with an id of the marker map",
    "too_few_markers": "fewer usable markers than PnPSettings.min_markers",
    "ambiguous": "two distinct poses explain the corners about equally well",
    "reprojection_error": "reprojection RMSE above PnPSettings.max_reproj_rmse_px",
    "pnp_failed": "OpenCV PnP returned no valid solution in front of the camera",
}


@dataclass(frozen=True)
class PnPSettings:
    """Camera pose from all visible known markers jointly.

    ``min_markers``: fewest map markers a pose may rest on. ``max_reproj_rmse_px``: gate on
    the final reprojection RMSE over all used corners. ``max_marker_reproj_px``: a marker
    whose own RMSE exceeds this after the joint fit is discarded as an outlier (and the fit
    redone) while at least ``min_markers`` remain. ``ambiguity_ratio``: the pose is
    dropped as ambiguous when the best *distinct* rival (rotation differing by more than
    ``ambiguity_min_angle_deg``) reaches an RMSE below ``ratio x`` the best one.
    ``refine``: joint Levenberg–Marquardt refinement (``solvePnPRefineLM``).
    ``max_seed_markers``: the largest markers (image perimeter) whose two IPPE solutions
    seed the candidate set (with one SQPnP over all corners).
    """
    min_markers: int = 1
    max_reproj_rmse_px: float = 1.0
    max_marker_reproj_px: float = 2.0
    ambiguity_ratio: float = 2.0
    ambiguity_min_angle_deg: float = 3.0
    refine: bool = True
    max_seed_markers: int = 6

    def __post_init__(self):
        if isinstance(self.min_markers, bool) or not isinstance(self.min_markers, int) \
                or self.min_markers < 1:
            raise ValueError(f"min_markers must be an integer >= 1; received {self.min_markers!r}")
        for name in ("max_reproj_rmse_px", "max_marker_reproj_px", "ambiguity_min_angle_deg"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0; received {v!r}")
        if isinstance(self.max_seed_markers, bool) or not isinstance(self.max_seed_markers, int) \
                or self.max_seed_markers < 1:
            raise ValueError("max_seed_markers must be an integer >= 1; received "
                             f"{self.max_seed_markers!r}")
        if not (isinstance(self.ambiguity_ratio, (int, float)) and self.ambiguity_ratio >= 1.0):
            raise ValueError("ambiguity_ratio must be >= 1 (1 disables the check); received "
                             f"{self.ambiguity_ratio!r}")


@dataclass(frozen=True)
class CameraPoseEstimate:
    """Result of :func:`estimate_camera_pose` for one image.

    ``ok``/``reason`` (``"ok"`` or a key of :data:`DROP_REASONS`); ``T_world_cam`` (4, 4)
    (identity when not ok — never use it then); ``ids_used`` (markers in the final fit);
    ``reproj_rmse_px`` over all used corners and ``marker_rmse_px`` per used marker;
    ``ambiguity`` = rival RMSE / best RMSE (``inf`` when no distinct rival).
    """
    ok: bool
    reason: str
    T_world_cam: np.ndarray
    ids_used: np.ndarray
    n_detected: int
    n_known: int
    reproj_rmse_px: float
    marker_rmse_px: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ambiguity: float = float("inf")


def _fail(reason: str, n_detected: int, n_known: int, rmse: float = float("inf"),
          ids=None, ambiguity: float = float("inf")) -> CameraPoseEstimate:
    return CameraPoseEstimate(False, reason, np.eye(4),
                              np.zeros(0, dtype=np.int64) if ids is None else ids,
                              n_detected, n_known, rmse, np.zeros(0), ambiguity)


def _project(T_cam_world: np.ndarray, Xw: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Project ``(P, 3)`` world points with ``(C, 4, 4)`` poses: ``(C, P, 2)`` pixels, depths."""
    Xc = np.einsum("cij,pj->cpi", T_cam_world[:, :3, :3], Xw) + T_cam_world[:, None, :3, 3]
    z = Xc[..., 2]
    zs = np.where(z > 1e-9, z, 1e-9)
    uv = np.stack([K[0, 0] * Xc[..., 0] / zs + K[0, 2], K[1, 1] * Xc[..., 1] / zs + K[1, 2]], -1)
    return uv, z


def transform_from_rvec_tvec(rvec, tvec) -> np.ndarray:
    """``(4, 4)`` transform of an OpenCV Rodrigues vector ``rvec`` and translation ``tvec``."""
    import cv2  # noqa: PLC0415
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3, 1))
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(tvec, dtype=np.float64).ravel()
    return T


def _checked_pose_inputs(detections, field, K, dist_coeffs) -> np.ndarray:
    """Validate the inputs of :func:`estimate_camera_pose`; ``K`` as a float64 array."""
    if not isinstance(detections, Detections):
        raise TypeError(f"detections must be a Detections; received {type(detections).__name__}")
    if not isinstance(field, MarkerField):
        raise TypeError(f"field must be a MarkerField; received {type(field).__name__}")
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.isfinite(K).all():
        raise ValueError(f"K must be a finite (3, 3) camera matrix; received shape {K.shape}")
    if dist_coeffs is not None and np.any(np.asarray(dist_coeffs) != 0):
        raise ValueError("estimate_camera_pose supports undistorted images only "
                         "(dist_coeffs None or zeros); received non-zero coefficients")
    return K


def _usable_detections(ids: np.ndarray, field: MarkerField) -> tuple[np.ndarray, np.ndarray]:
    """Map rows of the detected ids and the mask of those in the map and seen only once."""
    rows = field.index_of(ids)
    uniq, counts = np.unique(ids, return_counts=True)
    dup = np.isin(ids, uniq[counts > 1])
    keep = (rows >= 0) & ~dup
    return rows, keep


def _ippe_candidates(img: np.ndarray, T_wm: np.ndarray, local: np.ndarray, K: np.ndarray,
                     max_seed_markers: int) -> list:
    """Camera poses from both IPPE_SQUARE solutions of the largest markers (list of (C, 4, 4))."""
    import cv2  # noqa: PLC0415
    zero = np.zeros(5)
    perim = np.linalg.norm(img - np.roll(img, -1, axis=1), axis=-1).sum(-1)
    seeds = np.argsort(-perim, kind="stable")[:max_seed_markers]
    T_cm = []
    seed_of = []
    for m in seeds:
        try:
            n_sol, rvecs, tvecs, _ = cv2.solvePnPGeneric(local, img[m], K, zero,
                                                         flags=cv2.SOLVEPNP_IPPE_SQUARE)
        except cv2.error:
            n_sol = 0
        for k in range(int(n_sol)):
            T_cm.append(transform_from_rvec_tvec(rvecs[k], tvecs[k]))
            seed_of.append(m)
    return [np.stack(T_cm) @ invert_transform(T_wm[np.asarray(seed_of)])] if T_cm else []


def _sqpnp_candidate(world: np.ndarray, img: np.ndarray, K: np.ndarray) -> list:
    """The camera pose from one SQPnP over all corners (a list of one (1, 4, 4), or empty)."""
    import cv2  # noqa: PLC0415
    Xw = world.reshape(-1, 3)
    uv = img.reshape(-1, 2)
    try:
        ok, rvec, tvec = cv2.solvePnP(Xw, uv, K, np.zeros(5), flags=cv2.SOLVEPNP_SQPNP)
        if ok:
            return [transform_from_rvec_tvec(rvec, tvec)[None]]
    except cv2.error:
        pass
    return []


@dataclass(frozen=True)
class _Correspondences:
    """The kept markers' world corners (M, 4, 3), their image corners (M, 4, 2), and K."""
    world: np.ndarray
    img: np.ndarray
    K: np.ndarray


def _marker_errors(Tc: np.ndarray, obs: _Correspondences, use: np.ndarray) -> np.ndarray:
    """(C, M) per-marker RMS reprojection error (px) of poses Tc; 1e6 when a corner is behind."""
    pts = obs.world[use].reshape(-1, 3)
    proj, z = _project(Tc, pts, obs.K)
    e2 = ((proj - obs.img[use].reshape(-1, 2)[None]) ** 2).sum(-1).reshape(len(Tc), -1, 4)
    e = np.sqrt(e2.mean(-1))
    behind = (z.reshape(len(Tc), -1, 4) <= 1e-6).any(-1)
    return np.where(behind, 1e6, e)


def _refined_pose(T: np.ndarray, obs: _Correspondences, use: np.ndarray,
                  refine: bool) -> np.ndarray:
    """``T`` (cam <- world) refined by ``solvePnPRefineLM`` on the used markers (if ``refine``)."""
    if not refine:
        return T
    import cv2  # noqa: PLC0415
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    rvec, tvec = cv2.solvePnPRefineLM(
        obs.world[use].reshape(-1, 3), obs.img[use].reshape(-1, 2), obs.K, np.zeros(5), rvec.copy(),
        T[:3, 3].copy(), criteria=(cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 50, 1e-12))
    return transform_from_rvec_tvec(rvec, tvec)


def _rmse(e: np.ndarray) -> float:
    """Root mean square of the per-marker errors ``e``."""
    return float(np.sqrt((e ** 2).mean()))


def _drop_outlier_markers(best: np.ndarray, obs: _Correspondences, use: np.ndarray,
                          settings: PnPSettings) -> tuple[np.ndarray, np.ndarray]:
    """Drop the worst marker above max_marker_reproj_px and refit, repeatedly (``use`` in place)."""
    while True:
        per = _marker_errors(best[None], obs, use)[0]
        worst = int(np.argmax(per))
        if per[worst] <= settings.max_marker_reproj_px or use.sum() <= settings.min_markers:
            break
        use[np.flatnonzero(use)[worst]] = False
        best = _refined_pose(best, obs, use, settings.refine)
    return best, per


def _ranked_candidates(cands: np.ndarray, obs: _Correspondences, cap: float):
    """Candidate order by robust score, the scores, and the best candidate's inlier markers."""
    # Robust choice: a truncated quadratic over markers, so that one wrong marker (a false
    # id, or a marker behind the camera) cannot veto the right pose.
    E = _marker_errors(cands, obs, np.ones(obs.img.shape[0], dtype=bool))
    sc = (np.minimum(E, cap) ** 2).sum(-1)
    order = np.argsort(sc, kind="stable")
    return order, sc, E[order[0]] <= cap


def _ambiguity(cands: np.ndarray, order: np.ndarray, sc: np.ndarray, cap: float,
               best: np.ndarray, rmse: float, obs: _Correspondences, use: np.ndarray,
               settings: PnPSettings) -> float:
    """RMSE of the best distinct rival (refined on the same markers) / best RMSE; inf if none."""
    ambiguity = float("inf")
    min_ang = np.deg2rad(settings.ambiguity_min_angle_deg)
    for j in order[1:]:
        if sc[j] >= cap ** 2 * obs.img.shape[0]:
            break
        if _angle(cands[j][:3, :3], best[:3, :3]) > min_ang:
            rival = _refined_pose(cands[j], obs, use, settings.refine)
            if _angle(rival[:3, :3], best[:3, :3]) > min_ang:
                rival_rmse = _rmse(_marker_errors(rival[None], obs, use)[0])
                ambiguity = rival_rmse / max(rmse, 1e-3)
            break
    return ambiguity


def estimate_camera_pose(detections: Detections, field: MarkerField, K,
                         settings: PnPSettings | None = None,
                         dist_coeffs=None) -> CameraPoseEstimate:
    """Camera pose ``T_world_cam`` from all detected markers of ``field`` jointly.

    1. Keep detections whose id is in the map (an id seen twice in one image is ambiguous
       and discarded). 2. Candidates: both IPPE_SQUARE solutions of every marker (moved to
       the world via the map; the ``max_seed_markers`` largest) and one SQPnP over all
       corners; each is scored with a truncated quadratic of the per-marker RMS errors (a corner behind the camera
       counts as a gross error), so one false marker cannot veto the right pose. 3. The
       best candidate is refined with ``solvePnPRefineLM`` on its inlier markers; markers
       with an RMS error above ``max_marker_reproj_px`` are discarded worst first and the
       fit redone. 4. The best *distinct* rival is refined on the same markers for the
       ambiguity test. 5. The RMSE gate. Failures return ``ok=False`` with a reason
       (:data:`DROP_REASONS`).
    """
    if settings is not None and not isinstance(settings, PnPSettings):
        raise TypeError(f"settings must be a PnPSettings or None; received "
                        f"{type(settings).__name__}")
    settings = settings or PnPSettings()
    K = _checked_pose_inputs(detections, field, K, dist_coeffs)
    import cv2  # noqa: F401,PLC0415  (required from here on, even when nothing was detected)
    n_det = detections.n
    if n_det == 0:
        return _fail("no_markers", 0, 0)
    ids = np.ravel(detections.ids)
    rows, keep = _usable_detections(ids, field)
    n_known = int(keep.sum())
    if n_known == 0:
        return _fail("no_known_markers", n_det, 0)
    if n_known < settings.min_markers:
        return _fail("too_few_markers", n_det, n_known)
    ids_k = ids[keep]
    obs, cands = _candidates(detections, field, rows[keep], keep, K, settings)
    if not cands:
        return _fail("pnp_failed", n_det, n_known, ids=ids_k)
    return _best_pose(np.concatenate(cands), obs, settings, ids_k, n_det, n_known)


def _candidates(detections: Detections, field: MarkerField, rows: np.ndarray, keep: np.ndarray,
                K: np.ndarray, settings: PnPSettings) -> tuple:
    """``(correspondences, candidate poses)`` of the kept markers (map rows ``rows``): both
    IPPE solutions of the largest markers, and SQPnP on all corners."""
    img = detections.corners_px[keep].astype(np.float64)             # M,4,2
    T_wm = np.asarray(field.T_world_marker, dtype=np.float64)[rows]
    local = marker_corners_local(field.side_m)
    world = np.einsum("mij,cj->mci", T_wm[:, :3, :3], local) + T_wm[:, None, :3, 3]  # M,4,3
    cands = (_ippe_candidates(img, T_wm, local, K, settings.max_seed_markers)
             + _sqpnp_candidate(world, img, K))
    return _Correspondences(world, img, K), cands


def _best_pose(cands: np.ndarray, obs: _Correspondences, settings: PnPSettings,
               ids_k: np.ndarray, n_det: int, n_known: int) -> CameraPoseEstimate:
    """The best candidate refined on its inlier markers (outlier markers dropped), then the
    ambiguity, marker-count and reprojection gates."""
    cap = 4.0 * settings.max_marker_reproj_px  # truncation of the robust candidate score
    order, sc, use = _ranked_candidates(cands, obs, cap)
    if not use.any():
        return _fail("pnp_failed", n_det, n_known, ids=ids_k)
    best = _refined_pose(cands[order[0]], obs, use, settings.refine)
    best, per = _drop_outlier_markers(best, obs, use, settings)  # updates use
    rmse = _rmse(per)
    ambiguity = _ambiguity(cands, order, sc, cap, best, rmse, obs, use, settings)
    if ambiguity < settings.ambiguity_ratio:
        return _fail("ambiguous", n_det, n_known, rmse, ids_k[use], ambiguity)
    if use.sum() < settings.min_markers:
        return _fail("too_few_markers", n_det, n_known, rmse, ids_k[use], ambiguity)
    if rmse > settings.max_reproj_rmse_px or per.max() >= 1e6:
        return _fail("reprojection_error", n_det, n_known, rmse, ids_k[use], ambiguity)
    T_world_cam = invert_transform(best)
    return CameraPoseEstimate(True, "ok", T_world_cam, ids_k[use], n_det, n_known, rmse,
                              per, ambiguity)


def _angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def undistort_points(points_px: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """Distorted pixel coordinates ``(..., 2)`` -> ideal pinhole pixels with the same ``K``."""
    import cv2  # noqa: PLC0415
    pts = np.asarray(points_px, dtype=np.float64)
    if pts.size == 0 or not any(float(v) != 0.0 for v in dist):
        return pts.copy()
    flat = pts.reshape(-1, 1, 2)
    out = cv2.undistortPointsIter(flat, np.asarray(K, np.float64),
                                  np.asarray(dist, np.float64), None, np.asarray(K, np.float64),
                                  (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10))
    return out.reshape(pts.shape)
