"""ArUco markers: dictionary, marker images, the marker map, detection.

The camera pose from the detections is :mod:`simcalib.targets.marker_pnp`; how calibration
and map errors move it, :mod:`simcalib.targets.pnp_sensitivity` (all OpenCV marker code is
in this folder).

Marker frame (documented once, tested against the pose MuJoCo renders): a marker of side
``L`` has its origin at the marker centre, +z out of the printed face (towards the viewer),
+x to the right and +y up when the marker image is viewed upright. Its corners, in OpenCV's
detection order (top-left, top-right, bottom-right, bottom-left of the upright image), are
``(-L/2, L/2, 0), (L/2, L/2, 0), (L/2, -L/2, 0), (-L/2, -L/2, 0)`` — the order
``SOLVEPNP_IPPE_SQUARE`` expects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CORNER_REFINEMENTS", "DICTIONARY", "DetectorSettings", "Detections", "MarkerField",
           "detect_markers", "make_detector", "marker_corners_local", "marker_image",
           "marker_png", "refine_corners_edges"]

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
    g = np.asarray(gray, dtype=np.float32)
    C = np.asarray(corners_px, dtype=np.float64).copy()
    if C.size == 0:
        return C.reshape(0, 4, 2)
    s = np.linspace(-1.0, 1.0, int(n_samples))
    t = np.linspace(0.15, 0.85, int(n_profiles))
    for _ in range(int(iterations)):
        ep, w = _edge_crossings(g, C, s, t, half_width_px, min_contrast)
        C = _corners_from_edges(ep, w, C)
    return C


def _edge_crossings(g: np.ndarray, C: np.ndarray, s: np.ndarray, t: np.ndarray,
                    half_width_px: float, min_contrast: float) -> tuple:
    """``(points (N, 4, S, 2), weights (N, 4, S))``: along the profiles ``t`` of each edge
    (edge i from corner i to corner i+1), the 50 % dark/bright crossing of the image ``g``
    sampled at ``s`` (in units of the profile half-width); weight 1 where the profile's
    contrast exceeds ``min_contrast``."""
    import cv2  # noqa: PLC0415
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
    return base + nrm[..., None, :] * off[..., None], w


def _corners_from_edges(ep: np.ndarray, w: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Corners ``(N, 4, 2)`` where the total-least-squares lines through the edge points
    ``ep`` (weights ``w``) of adjacent edges intersect; a corner keeps its value in ``C``
    when an edge has fewer than 5 valid points, the lines are near parallel, or it would
    move by 2 px or more."""
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
    return np.where(good[..., None], newC, C)
