"""All OpenCV ArUco marker code: dictionary, marker images, detection, PnP.

Marker frame (documented once, tested against the pose MuJoCo renders): a marker of side
``L`` has its origin at the marker centre, +z out of the printed face (towards the viewer),
+x to the right and +y up when the marker image is viewed upright. Its corners, in OpenCV's
detection order (top-left, top-right, bottom-right, bottom-left of the upright image), are
``(-L/2, L/2, 0), (L/2, L/2, 0), (L/2, -L/2, 0), (-L/2, -L/2, 0)`` — the order
``SOLVEPNP_IPPE_SQUARE`` expects.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "undistort_points",
    "map_pose_covariance",
    "map_pose_jacobians",
    "map_error_variances",
    "intrinsics_pose_jacobians",
    "check_camera_poses",
    "CORNER_REFINEMENTS",
    "DICTIONARY",
    "DROP_REASONS",
    "CameraPoseEstimate",
    "DetectorSettings",
    "Detections",
    "INTRINSICS_PARAMETERS",
    "MarkerField",
    "PnPSettings",
    "detect_markers",
    "estimate_camera_pose",
    "intrinsics_pose_sensitivity",
    "make_detector",
    "marker_corners_local",
    "marker_image",
    "marker_png",
    "perturbed_intrinsics",
    "refine_corners_edges",
]

#: Default ArUco dictionary (250 ids, 4x4 bits: large cells, robust at low resolution).
DICTIONARY = "DICT_4X4_250"


def _cv2():
    import cv2  # local import: keep `import simcalib` light
    return cv2


def marker_corners_local(side_m: float) -> np.ndarray:
    """``(4, 3)`` corners of a marker in its own frame, OpenCV detection order."""
    h = 0.5 * float(side_m)
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def marker_image(marker_id: int, pixels: int = 256, dictionary: str = DICTIONARY,
                 border_bits: int = 1) -> np.ndarray:
    """Upright ``(pixels, pixels)`` uint8 image of marker ``marker_id`` (black border)."""
    cv2 = _cv2()
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary))
    return cv2.aruco.generateImageMarker(d, int(marker_id), int(pixels), borderBits=border_bits)


def marker_png(marker_id: int, pixels: int = 256, dictionary: str = DICTIONARY,
               quiet_zone_px: int = 0) -> bytes:
    """PNG bytes (RGB) of :func:`marker_image`, optionally with a white quiet zone, for
    use as a MuJoCo texture. With ``quiet_zone_px > 0`` the black square covers the central
    ``pixels`` of an image of ``pixels + 2 * quiet_zone_px`` (size the geom accordingly)."""
    cv2 = _cv2()
    img = marker_image(marker_id, pixels, dictionary)
    if quiet_zone_px > 0:
        img = cv2.copyMakeBorder(img, quiet_zone_px, quiet_zone_px, quiet_zone_px,
                                 quiet_zone_px, cv2.BORDER_CONSTANT, value=255)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(img, cv2.COLOR_GRAY2RGB))
    if not ok:
        raise RuntimeError("OpenCV failed to encode the marker PNG")
    return buf.tobytes()


@dataclass(frozen=True)
class MarkerField:
    """Known map of markers: ids ``(M,)``, side ``side_m`` (black square edge, metres),
    and ``T_world_marker`` ``(M, 4, 4)`` in the marker frame documented above."""
    dictionary: str
    ids: np.ndarray
    side_m: float
    T_world_marker: np.ndarray

    def corners_world(self) -> np.ndarray:
        """``(M, 4, 3)`` world coordinates of every marker's corners (detection order)."""
        local = marker_corners_local(self.side_m)
        R = self.T_world_marker[:, :3, :3]
        t = self.T_world_marker[:, :3, 3]
        return np.einsum("mij,cj->mci", R, local) + t[:, None, :]

    def __post_init__(self):
        ids = np.ravel(np.asarray(self.ids))
        if ids.size and not np.issubdtype(ids.dtype, np.integer):
            raise TypeError(f"MarkerField.ids must be integers; received dtype {ids.dtype}")
        vals, counts = np.unique(ids, return_counts=True)
        if (counts > 1).any():
            raise ValueError("MarkerField.ids must be unique; received duplicates "
                             f"{vals[counts > 1].tolist()}")
        if not (np.isfinite(self.side_m) and self.side_m > 0):
            raise ValueError(f"MarkerField.side_m must be > 0 metres; received {self.side_m}")
        T = np.asarray(self.T_world_marker, dtype=np.float64)
        if T.shape != (ids.size, 4, 4):
            raise ValueError(f"MarkerField.T_world_marker must have shape ({ids.size}, 4, 4) "
                             f"(one per id); received {T.shape}")

    def index_of(self, ids: np.ndarray) -> np.ndarray:
        """Row of each id in this field (``-1`` for ids not in the map)."""
        ids = np.ravel(np.asarray(ids))
        own = np.ravel(np.asarray(self.ids))
        order = np.argsort(own)
        pos = np.searchsorted(own[order], ids)
        pos = np.clip(pos, 0, max(own.size - 1, 0))
        found = own.size > 0
        out = np.where(found & (own[order][pos] == ids) if found else False, order[pos], -1)
        return np.asarray(out, dtype=np.int64).reshape(ids.shape)


# ============================================================================ detection
#: Corner refinement names -> OpenCV ``cv2.aruco.CORNER_REFINE_*`` attribute names.
CORNER_REFINEMENTS = {
    "none": "CORNER_REFINE_NONE",
    "subpix": "CORNER_REFINE_SUBPIX",
    "contour": "CORNER_REFINE_CONTOUR",
    "apriltag": "CORNER_REFINE_APRILTAG",
}


@dataclass(frozen=True)
class DetectorSettings:
    """ArUco detection settings.

    ``corner_refinement``: OpenCV's per-corner refinement (one of :data:`CORNER_REFINEMENTS`;
    ``subpix`` is best of OpenCV's on renders). ``edge_refinement``: afterwards, re-locate
    each marker's four outer edges at the 50 % dark/bright crossing along many profiles and
    intersect the fitted lines (:func:`refine_corners_edges`) — removes the ~0.2–0.4 px
    inward corner bias of ``subpix`` that makes markers look small (docs/vision.md).
    ``min_marker_perimeter_rate``: OpenCV's ``minMarkerPerimeterRate`` (perimeter / largest
    image side) — smaller markers are ignored. ``adaptive_thresh_win_px``: OpenCV's
    adaptive-threshold window sizes ``(min, max, step)``; default two passes (3 and 23 px)
    found the same markers with the same corners as OpenCV's three (3, 13, 23) on renders
    at 640x480 and 320x240; a single 23 px pass loses small markers and corner quality at
    low resolution (docs/vision.md).
    """
    dictionary: str = DICTIONARY
    corner_refinement: str = "subpix"
    edge_refinement: bool = True
    subpix_window_px: int = 5
    min_marker_perimeter_rate: float = 0.03
    adaptive_thresh_win_px: tuple = (3, 23, 20)

    def __post_init__(self):
        win = tuple(self.adaptive_thresh_win_px) if isinstance(
            self.adaptive_thresh_win_px, (tuple, list)) else None
        if (win is None or len(win) != 3
                or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                           for v in win)
                or not (3 <= win[0] <= win[1] and win[2] >= 1)):
            raise ValueError("adaptive_thresh_win_px must be (min, max, step) integers with "
                             f"3 <= min <= max and step >= 1; received "
                             f"{self.adaptive_thresh_win_px!r}")
        object.__setattr__(self, "adaptive_thresh_win_px", tuple(int(v) for v in win))
        if self.corner_refinement not in CORNER_REFINEMENTS:
            raise ValueError(f"corner_refinement must be one of {sorted(CORNER_REFINEMENTS)}; "
                             f"received {self.corner_refinement!r}")
        if not isinstance(self.dictionary, str) or not self.dictionary.startswith("DICT_"):
            raise ValueError("dictionary must be an OpenCV ArUco dictionary name such as "
                             f"'DICT_4X4_250'; received {self.dictionary!r}")
        if not isinstance(self.subpix_window_px, int) or not 1 <= self.subpix_window_px <= 20:
            raise ValueError("subpix_window_px must be an integer in [1, 20]; received "
                             f"{self.subpix_window_px!r}")
        if not 0.0 < float(self.min_marker_perimeter_rate) < 4.0:
            raise ValueError("min_marker_perimeter_rate must be in (0, 4); received "
                             f"{self.min_marker_perimeter_rate!r}")


def make_detector(settings: DetectorSettings | None = None):
    """An OpenCV ``cv2.aruco.ArucoDetector`` configured from ``settings``."""
    settings = settings or DetectorSettings()
    cv2 = _cv2()
    if not hasattr(cv2.aruco, settings.dictionary):
        names = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        raise ValueError(f"unknown ArUco dictionary {settings.dictionary!r}; valid: {names}")
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, settings.dictionary))
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = int(getattr(cv2.aruco,
                                                CORNER_REFINEMENTS[settings.corner_refinement]))
    params.cornerRefinementWinSize = int(settings.subpix_window_px)
    params.cornerRefinementMinAccuracy = 0.01
    params.cornerRefinementMaxIterations = 50
    params.minMarkerPerimeterRate = float(settings.min_marker_perimeter_rate)
    lo, hi, step = settings.adaptive_thresh_win_px
    params.adaptiveThreshWinSizeMin = lo
    params.adaptiveThreshWinSizeMax = hi
    params.adaptiveThreshWinSizeStep = step
    return cv2.aruco.ArucoDetector(dictionary, params)


@dataclass(frozen=True)
class Detections:
    """Markers found in one image: ``ids`` ``(N,)`` int and ``corners_px`` ``(N, 4, 2)``
    (pixel coordinates, OpenCV convention: pixel centres at integers, detection order)."""
    ids: np.ndarray
    corners_px: np.ndarray
    n_rejected: int = 0

    @property
    def n(self) -> int:
        return int(self.ids.shape[0])


def _as_gray(image) -> np.ndarray:
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise TypeError(f"image must be uint8; received dtype {img.dtype}")
    if img.ndim == 3 and img.shape[2] == 3:
        return _cv2().cvtColor(img, _cv2().COLOR_RGB2GRAY)
    if img.ndim == 2:
        return img
    raise ValueError(f"image must be (H, W) gray or (H, W, 3) RGB; received shape {img.shape}")


def detect_markers(image, detector=None, settings: DetectorSettings | None = None
                   ) -> Detections:
    """Detect ArUco markers in a uint8 gray or RGB image (``np.ravel(ids)`` always).

    ``detector``: a ``cv2.aruco.ArucoDetector`` (made from ``settings`` when omitted; pass
    one to avoid rebuilding it per frame). Edge refinement follows ``settings``.
    """
    settings = settings or DetectorSettings()
    gray = _as_gray(image)
    if detector is None:
        detector = make_detector(settings)
    corners, ids, rejected = detector.detectMarkers(gray)
    if ids is None or len(corners) == 0:
        return Detections(np.zeros(0, dtype=np.int64), np.zeros((0, 4, 2)),
                          len(rejected) if rejected is not None else 0)
    ids = np.ravel(ids).astype(np.int64)
    C = np.asarray(corners, dtype=np.float64).reshape(-1, 4, 2)
    if settings.edge_refinement:
        C = refine_corners_edges(gray, C)
    return Detections(ids, C, len(rejected) if rejected is not None else 0)


def refine_corners_edges(gray: np.ndarray, corners_px: np.ndarray, *, half_width_px: float = 3.0,
                         n_profiles: int = 24, n_samples: int = 13, iterations: int = 2,
                         min_contrast: float = 20.0) -> np.ndarray:
    """Refine marker corners ``(N, 4, 2)`` by fitting the four outer edges of each marker.

    Along ``n_profiles`` normals of each edge (its middle 70 %, away from corners) the
    image is sampled bilinearly and the 50 % crossing between the dark border and the
    bright surround is found; a total-least-squares line through the crossings gives the
    edge, and adjacent edges intersect in the corner. Straight edges are exact for a
    pinhole camera without distortion. Unlike a corner-only refinement this uses the
    whole edge and is unbiased by blur (blur is symmetric about the 50 % level). An edge
    with fewer than 5 valid profiles (too little contrast, ``< min_contrast`` grey levels)
    keeps the input corners. Profile half-width is at most 0.45 of a marker cell.
    """
    cv2 = _cv2()
    g = np.asarray(gray, dtype=np.float32)
    C = np.asarray(corners_px, dtype=np.float64).copy()
    if C.size == 0:
        return C.reshape(0, 4, 2)
    s = np.linspace(-1.0, 1.0, int(n_samples))
    t = np.linspace(0.15, 0.85, int(n_profiles))
    for _ in range(int(iterations)):
        P0 = C
        P1 = np.roll(C, -1, axis=1)  # edge i runs from corner i to corner i+1
        d = P1 - P0
        length = np.linalg.norm(d, axis=-1)
        d = d / np.maximum(length, 1e-9)[..., None]
        # Detection order is clockwise on screen (y down), so (dy, -dx) points outwards.
        nrm = np.stack([d[..., 1], -d[..., 0]], axis=-1)
        h = np.minimum(half_width_px, 0.45 * length / 6.0)  # <= 0.45 cell (4x4 + border)
        base = P0[..., None, :] + (P1 - P0)[..., None, :] * t[:, None]        # N,4,S,2
        pts = base[..., None, :] + nrm[..., None, None, :] * (s[:, None] * h[..., None, None, None])
        # maps shaped (edges, samples): OpenCV limits each map side to < 32767
        flat = pts.reshape(-1, t.size * s.size, 2).astype(np.float32)
        vals = cv2.remap(g, np.ascontiguousarray(flat[..., 0]), np.ascontiguousarray(flat[..., 1]),
                         cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
                         ).reshape(pts.shape[:-1])
        lo = vals[..., :3].mean(-1)
        hi = vals[..., -3:].mean(-1)
        mid = 0.5 * (lo + hi)
        above = vals >= mid[..., None]
        idx = np.clip(np.argmax(above, axis=-1), 1, s.size - 1)
        v0 = np.take_along_axis(vals, (idx - 1)[..., None], -1)[..., 0]
        v1 = np.take_along_axis(vals, idx[..., None], -1)[..., 0]
        frac = np.clip((mid - v0) / np.maximum(v1 - v0, 1e-6), 0.0, 1.0)
        off = (s[idx - 1] + frac * (s[1] - s[0])) * h[..., None]
        w = ((hi - lo) > min_contrast).astype(np.float64)
        ep = base + nrm[..., None, :] * off[..., None]
        cnt = w.sum(-1)
        mu = (ep * w[..., None]).sum(-2) / np.maximum(cnt, 1.0)[..., None]
        X = (ep - mu[..., None, :]) * np.sqrt(w)[..., None]
        cov = np.einsum("...si,...sj->...ij", X, X)
        _, evecs = np.linalg.eigh(cov)
        direction = evecs[..., :, 1]
        nl = np.stack([-direction[..., 1], direction[..., 0]], axis=-1)
        cl = (nl * mu).sum(-1)
        # corner i is the intersection of edge i-1 and edge i
        A = np.stack([np.roll(nl, 1, axis=1), nl], axis=-2)
        b = np.stack([np.roll(cl, 1, axis=1), cl], axis=-1)
        det = np.linalg.det(A)
        ok_edge = cnt >= 5
        good = ok_edge & np.roll(ok_edge, 1, axis=1) & (np.abs(det) > 1e-3)
        A_safe = np.where(good[..., None, None], A, np.eye(2))
        b_safe = np.where(good[..., None], b, 0.0)
        newC = np.linalg.solve(A_safe, b_safe[..., None])[..., 0]
        # a refinement that moves a corner by more than 2 px is not trusted
        good &= np.linalg.norm(newC - C, axis=-1) < 2.0
        C = np.where(good[..., None], newC, C)
    return C


# ================================================================================= PnP
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


def _rvec_t_to_T(rvec, tvec) -> np.ndarray:
    cv2 = _cv2()
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
    cv2 = _cv2()
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
            T_cm.append(_rvec_t_to_T(rvecs[k], tvecs[k]))
            seed_of.append(m)
    return [np.stack(T_cm) @ _inv(T_wm[np.asarray(seed_of)])] if T_cm else []


def _sqpnp_candidate(world: np.ndarray, img: np.ndarray, K: np.ndarray) -> list:
    """The camera pose from one SQPnP over all corners (a list of one (1, 4, 4), or empty)."""
    cv2 = _cv2()
    Xw = world.reshape(-1, 3)
    uv = img.reshape(-1, 2)
    try:
        ok, rvec, tvec = cv2.solvePnP(Xw, uv, K, np.zeros(5), flags=cv2.SOLVEPNP_SQPNP)
        if ok:
            return [_rvec_t_to_T(rvec, tvec)[None]]
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
    cv2 = _cv2()
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    rvec, tvec = cv2.solvePnPRefineLM(
        obs.world[use].reshape(-1, 3), obs.img[use].reshape(-1, 2), obs.K, np.zeros(5), rvec.copy(),
        T[:3, 3].copy(), criteria=(cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 50, 1e-12))
    return _rvec_t_to_T(rvec, tvec)


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
    _cv2()  # OpenCV is required from here on, even when nothing was detected
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
    img = detections.corners_px[keep].astype(np.float64)             # M,4,2
    T_wm = np.asarray(field.T_world_marker, dtype=np.float64)[rows[keep]]
    local = marker_corners_local(field.side_m)
    world = np.einsum("mij,cj->mci", T_wm[:, :3, :3], local) + T_wm[:, None, :3, 3]  # M,4,3

    # --- candidates: both IPPE solutions of the largest markers, and SQPnP on all corners
    cands = (_ippe_candidates(img, T_wm, local, K, settings.max_seed_markers)
             + _sqpnp_candidate(world, img, K))
    if not cands:
        return _fail("pnp_failed", n_det, n_known, ids=ids_k)
    cands = np.concatenate(cands)

    obs = _Correspondences(world, img, K)
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
    T_world_cam = _inv(best)
    return CameraPoseEstimate(True, "ok", T_world_cam, ids_k[use], n_det, n_known, rmse,
                              per, ambiguity)


def _inv(T: np.ndarray) -> np.ndarray:
    from simcalib.geometry import invert_transform  # noqa: PLC0415
    return invert_transform(T)


def _angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


#: Parameters of :func:`intrinsics_pose_sensitivity`, in its column order: focal length
#: (relative, fx and fy together), principal point cx, cy (px), distortion k1, k2, p1, p2, k3.
INTRINSICS_PARAMETERS = ("focal_fraction", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3")


def perturbed_intrinsics(K, dist, step) -> tuple[np.ndarray, np.ndarray]:
    """``(K', dist')``: ``K``, ``dist`` moved by ``step`` (8,) in the parameters of
    :data:`INTRINSICS_PARAMETERS` (focal scaled by ``1 + step[0]``, the others added)."""
    step = np.asarray(step, dtype=np.float64)
    K2 = np.array(K, dtype=np.float64, copy=True)
    K2[0, 0] *= 1.0 + step[0]
    K2[1, 1] *= 1.0 + step[0]
    K2[0, 2] += step[1]
    K2[1, 2] += step[2]
    return K2, np.asarray(dist, dtype=np.float64) + step[3:8]


def check_camera_poses(T_world_cam, nonempty: bool = False) -> np.ndarray:
    """``(F, 4, 4)`` float camera poses of the pose-error sensitivities, or a ValueError
    naming the received shape (``nonempty``: at least one pose)."""
    T = np.asarray(T_world_cam, dtype=np.float64)
    if T.ndim != 3 or T.shape[1:] != (4, 4) or (nonempty and T.shape[0] == 0) \
            or not np.isfinite(T).all():
        raise ValueError(f"T_world_cam must be (F, 4, 4) finite poses"
                         f"{', F >= 1' if nonempty else ''}; received shape {T.shape}")
    return T


def _check_intrinsics_inputs(points_world, T_world_cam, K, dist, sigmas,
                             nonempty: bool = False) -> tuple:
    """``(T, K, dist, sigmas)`` as float arrays for the calibration sensitivities, or a
    ValueError naming what was received (``nonempty``: at least one pose)."""
    T = check_camera_poses(T_world_cam, nonempty)
    if len(points_world) != T.shape[0]:
        raise ValueError(f"points_world must hold one (P, 3) array per pose ({T.shape[0]}); "
                         f"received {len(points_world)}")
    K = np.asarray(K, dtype=np.float64)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    sig = np.asarray(sigmas, dtype=np.float64).ravel()
    if K.shape != (3, 3) or not np.isfinite(K).all() or dist.shape != (5,) \
            or not np.isfinite(dist).all():
        raise ValueError(f"K must be finite (3, 3) and dist 5 finite coefficients; received "
                         f"shapes {K.shape}, {dist.shape}")
    if sig.shape != (8,) or not np.isfinite(sig).all() or (sig < 0).any():
        raise ValueError(f"sigmas must be 8 finite numbers >= 0 "
                         f"({', '.join(INTRINSICS_PARAMETERS)}); received {sigmas!r}")
    return T, K, dist, sig


def intrinsics_pose_sensitivity(points_world, T_world_cam, K, dist, sigmas) -> np.ndarray:
    """How an error of the camera calibration moves the PnP camera poses: ``J`` (6, 8).

    ``points_world``: per frame the ``(P_f, 3)`` world points seen (marker corners, >= 4);
    ``T_world_cam``: ``(F, 4, 4)`` the camera's true poses; ``K``, ``dist`` (5,): the true
    calibration; ``sigmas`` (8,): the 1-sigma of each parameter of
    :data:`INTRINSICS_PARAMETERS` (0: skipped, column 0). The points are projected with the
    true calibration (no image is rendered), undistorted with a calibration moved by
    ``+-sigma`` of one parameter (as the pipeline undistorts with its believed calibration)
    and the pose is re-estimated (``solvePnPRefineLM`` from the true pose, pinhole ``K'``).
    Column ``j`` is the central difference ``(xi(+s_j) - xi(-s_j)) / 2`` averaged over the
    frames, ``xi = (rotvec, t)`` of ``T_true^-1 T_est`` (right-multiplied, camera frame): the
    pose error per 1-sigma of parameter ``j`` that is common to the frames (a calibration
    error is constant over a run). The pose error covariance is ``J J^T`` (independent
    parameters)."""
    cv2 = _cv2()
    from simcalib.geometry import rotvec_from_matrix  # noqa: PLC0415
    T, K, dist, sig = _check_intrinsics_inputs(points_world, T_world_cam, K, dist, sigmas,
                                               nonempty=True)
    zero = np.zeros(5)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-14)
    J = np.zeros((6, 8))
    n_used = 0
    for f in range(T.shape[0]):
        seen = _frame_projection(cv2, points_world[f], T[f], K, dist)
        if seen is None:
            continue
        Pw, T_cw, rvec0, img = seen
        tvec0 = T_cw[:3, 3].reshape(3, 1)
        col = np.zeros((6, 8))
        for j in np.flatnonzero(sig > 0):
            xi = []
            for K2, uv in _undistorted_at_plus_minus_sigma(img, K, dist, sig, j):
                rvec, tvec = cv2.solvePnPRefineLM(Pw, uv, K2, zero, rvec0.copy(), tvec0.copy(),
                                                  criteria=crit)
                T_est = _inv(_rvec_t_to_T(rvec, tvec))
                E = _inv(T[f]) @ T_est
                xi.append(np.concatenate([rotvec_from_matrix(E[:3, :3]), E[:3, 3]]))
            col[:, j] = 0.5 * (xi[0] - xi[1])
        J += col
        n_used += 1
    if n_used == 0:
        raise ValueError("no pose sees 4 or more points; the calibration sensitivity is "
                         "undefined")
    return J / n_used


def _frame_projection(cv2, points_world_f, T_world_cam_f, K, dist):
    """One frame's world points ``(P, 3)``, ``T_cam_world``, its Rodrigues vector and the
    points' pixels with the calibration ``(K, dist)`` ``(P, 2)``; None below 4 points."""
    Pw = np.asarray(points_world_f, dtype=np.float64).reshape(-1, 3)
    if Pw.shape[0] < 4:
        return None
    T_cw = _inv(T_world_cam_f)
    rvec, _ = cv2.Rodrigues(T_cw[:3, :3])
    img, _ = cv2.projectPoints(Pw, rvec, T_cw[:3, 3].reshape(3, 1), K, dist)
    return Pw, T_cw, rvec, img.reshape(-1, 2)


def _undistorted_at_plus_minus_sigma(img, K, dist, sig, j):
    """``[(K', points)]`` for the calibration moved by ``+sigma_j`` and by ``-sigma_j``:
    the pixels ``img`` undistorted as the pipeline would with that believed calibration."""
    out = []
    for s in (1.0, -1.0):
        step = np.zeros(8)
        step[j] = s * sig[j]
        K2, d2 = perturbed_intrinsics(K, dist, step)
        out.append((K2, undistort_points(img, K2, d2)))
    return out


def _pose_from_point_jacobian(pc: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For camera-frame points ``pc`` (..., 3): ``d uv / d pc`` (..., 2, 3) of the pinhole
    pixels (``K``) and ``d pc / d xi`` (..., 3, 6) for the pose error ``xi = (rotvec, t)``
    of ``T_true^-1 T_est`` (``pc = exp(-xi) pc_true``, first order ``[p]x omega - t``)."""
    x, y, z = pc[..., 0], pc[..., 1], pc[..., 2]
    duv_dpc = np.zeros(pc.shape[:-1] + (2, 3))
    duv_dpc[..., 0, 0] = K[0, 0] / z
    duv_dpc[..., 0, 2] = -K[0, 0] * x / z ** 2
    duv_dpc[..., 1, 1] = K[1, 1] / z
    duv_dpc[..., 1, 2] = -K[1, 1] * y / z ** 2
    dpc_dxi = np.zeros(pc.shape[:-1] + (3, 6))
    dpc_dxi[..., 0, 1], dpc_dxi[..., 0, 2] = -z, y          # [p]x
    dpc_dxi[..., 1, 0], dpc_dxi[..., 1, 2] = z, -x
    dpc_dxi[..., 2, 0], dpc_dxi[..., 2, 1] = -y, x
    dpc_dxi[..., :, 3:] = -np.eye(3)
    return duv_dpc, dpc_dxi


def _check_map_inputs(field, visible, T_world_cam, K):
    T = check_camera_poses(T_world_cam)
    vis = np.asarray(visible, dtype=bool)
    M = field.T_world_marker.shape[0]
    if vis.shape != (T.shape[0], M):
        raise ValueError(f"visible must be (F, M) = ({T.shape[0]}, {M}) booleans; received "
                         f"shape {vis.shape}")
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.isfinite(K).all():
        raise ValueError(f"K must be a finite (3, 3) matrix; received shape {K.shape}")
    return T, vis, K


def map_pose_jacobians(field: "MarkerField", visible: np.ndarray, T_world_cam, K) -> np.ndarray:
    """``(F, M, 6, 6)``: per frame ``f`` and marker ``m``, the first-order PnP pose error
    ``xi_f = (rotvec, t)`` of ``T_true^-1 T_est`` (right-multiplied, camera frame) per unit
    map error ``eta_m = (omega, dt)`` of marker ``m`` (the estimator's map holds the marker
    at ``T_world_marker @ [exp(omega) | dt]``, marker frame): ``xi_f = sum_m J[f, m] eta_m``.
    Multi-marker PnP on the undistorted pinhole corners of the markers ``visible[f]``
    (``K``): ``J[f, m] = -A_f^+ B_fm`` with ``A_f`` the Jacobian of the corners' pixels
    w.r.t. ``xi`` and ``B_fm`` w.r.t. ``eta_m``. Zero for markers not seen and for frames
    that see none."""
    T, vis, K = _check_map_inputs(field, visible, T_world_cam, K)
    M = field.T_world_marker.shape[0]
    local = marker_corners_local(field.side_m)                  # (4, 3)
    Pw = field.corners_world()                                  # (M, 4, 3)
    R_wm = field.T_world_marker[:, :3, :3]
    # d P_w / d eta per marker corner: (M, 4, 3, 6) = R_wm [ -[c]x , I ]
    skew_c = np.zeros((4, 3, 3))
    skew_c[:, 0, 1], skew_c[:, 0, 2] = -local[:, 2], local[:, 1]
    skew_c[:, 1, 0], skew_c[:, 1, 2] = local[:, 2], -local[:, 0]
    skew_c[:, 2, 0], skew_c[:, 2, 1] = -local[:, 1], local[:, 0]
    dP_deta = np.concatenate([np.einsum("mij,cjk->mcik", R_wm, -skew_c),
                              np.broadcast_to(R_wm[:, None], (M, 4, 3, 3))], axis=-1)
    J = np.zeros((T.shape[0], M, 6, 6))
    for f in np.flatnonzero(vis.any(axis=1)):
        ms = np.flatnonzero(vis[f])
        T_cw = _inv(T[f])
        pc = np.einsum("ij,mcj->mci", T_cw[:3, :3], Pw[ms]) + T_cw[:3, 3]      # (m, 4, 3)
        duv_dpc, dpc_dxi = _pose_from_point_jacobian(pc, K)
        A = (duv_dpc @ dpc_dxi).reshape(-1, 6)                              # (2P, 6)
        B = duv_dpc @ T_cw[:3, :3] @ dP_deta[ms]                           # (m, 4, 2, 6)
        Apinv = np.linalg.pinv(A)                                           # (6, 2P)
        Bm = B.reshape(len(ms), -1, 6)                                      # (m, 8, 6)
        Ap = Apinv.reshape(6, len(ms), 8).transpose(1, 0, 2)                # (m, 6, 8)
        J[f, ms] = -(Ap @ Bm)
    return J


def map_error_variances(position_std_m: float, rotation_std_rad: float) -> np.ndarray:
    """``(6,)`` variances of one marker's map error ``eta = (omega, dt)``: an angle
    ``~ N(0, rotation_std^2)`` about a uniform axis (``rotation_std^2 / 3`` per axis) and
    ``dt ~ N(0, position_std^2 I)``."""
    for name, v in (("position_std_m", position_std_m), ("rotation_std_rad", rotation_std_rad)):
        if isinstance(v, bool) or not np.isfinite(v) or v < 0:
            raise ValueError(f"{name} must be a finite number >= 0; received {v!r}")
    return np.array([rotation_std_rad ** 2 / 3.0] * 3 + [position_std_m ** 2] * 3)


def map_pose_covariance(field: "MarkerField", visible: np.ndarray, T_world_cam, K,
                        position_std_m: float, rotation_std_rad: float) -> np.ndarray:
    """Covariance (6, 6) of the part of a camera's PnP pose error that a marker-map error
    makes common to its frames (constant over a run: the map is surveyed once).

    The estimator's map holds each marker at ``T_world_marker @ [dR | dt]`` (marker frame,
    ``dt ~ N(0, position_std_m^2 I)``, ``dR`` by an angle ``~ N(0, rotation_std_rad^2)``
    about a uniform axis, independent per marker; :func:`map_error_variances`). First
    order, per frame (:func:`map_pose_jacobians`), averaged over the frames that see a
    marker: ``J_m`` (6, 6) per marker; the covariance is ``sum_m J_m D J_m^T``,
    ``D = diag(rotation_std^2 / 3 (x3), position_std^2 (x3))``. Cross-covariance between
    two cameras seeing the same markers is not returned."""
    T, vis, K = _check_map_inputs(field, visible, T_world_cam, K)
    D = map_error_variances(position_std_m, rotation_std_rad)
    if not D.any():
        return np.zeros((6, 6))
    used = vis.any(axis=1)
    if not used.any():
        raise ValueError("no pose sees a marker; the map-error sensitivity is undefined")
    J = map_pose_jacobians(field, vis, T, K).sum(axis=0) / int(used.sum())
    S = np.einsum("mij,j,mkj->ik", J, D, J)
    return 0.5 * (S + S.T)


def intrinsics_pose_jacobians(points_world, T_world_cam, K, dist, sigmas) -> np.ndarray:
    """``(F, 6, 8)``: per frame, the first-order PnP pose error ``xi = (rotvec, t)`` of
    ``T_true^-1 T_est`` (right-multiplied, camera frame) per 1-sigma ``sigmas`` (8,) of each
    calibration parameter of :data:`INTRINSICS_PARAMETERS` (a calibration error is constant
    over a run; how it moves the pose depends on where the points fall in the image).
    ``points_world``: per frame the ``(P_f, 3)`` world points seen; ``T_world_cam``
    ``(F, 4, 4)``; ``K``, ``dist`` (5,): the calibration. The points are projected with
    ``(K, dist)``, undistorted with the calibration moved by ``+-sigma_j`` and taken to
    normalised coordinates (central difference); the pose follows through the normal
    equations of PnP in normalised coordinates. Frames with fewer than 4 points: zero.
    No PnP iteration (the linear counterpart of :func:`intrinsics_pose_sensitivity`)."""
    cv2 = _cv2()
    T, K, dist, sig = _check_intrinsics_inputs(points_world, T_world_cam, K, dist, sigmas)
    K_norm = np.eye(3)
    J = np.zeros((T.shape[0], 6, 8))
    for f in range(T.shape[0]):
        seen = _frame_projection(cv2, points_world[f], T[f], K, dist)
        if seen is None:
            continue
        Pw, T_cw, _, img = seen
        pc = Pw @ T_cw[:3, :3].T + T_cw[:3, 3]
        duv_dpc, dpc_dxi = _pose_from_point_jacobian(pc, K_norm)
        A = (duv_dpc @ dpc_dxi).reshape(-1, 6)                  # normalised coordinates
        Apinv = np.linalg.pinv(A)
        for j in np.flatnonzero(sig > 0):
            n = [(uv - K2[:2, 2]) / np.diag(K2)[:2]
                 for K2, uv in _undistorted_at_plus_minus_sigma(img, K, dist, sig, j)]
            J[f, :, j] = Apinv @ (0.5 * (n[0] - n[1])).ravel()
    return J

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
