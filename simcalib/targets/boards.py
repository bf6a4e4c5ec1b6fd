"""Calibration boards as targets: ChArUco and AprilTag grids (OpenCV's board classes).

Board frame (OpenCV's own board object points, written once here and in docs/vision.md):
origin at the top-left outer corner of the pattern (the quiet zone lies outside it), +x to
the right and +y down as the board is seen printed from the front, +z = x × y pointing
INTO the board (away from a viewer in front of it). ``BoardConfig.size_m`` is the pattern's
(width, height); a point of the pattern is at ``(x, y, 0)`` with ``0 <= x <= width``,
``0 <= y <= height``.

* ChArUco (``kind="charuco"``): ``squares_x`` × ``squares_y`` chessboard squares of
  ``square_m`` with ArUco markers of ``marker_m`` in the white squares (OpenCV's
  non-legacy pattern, the top-left square black). Corner ids: the inner chessboard
  corners, row by row from the top left, ``id = row * (squares_x - 1) + col`` at
  ``((col + 1) * square_m, (row + 1) * square_m, 0)``.
* AprilTag grid (``kind="apriltag_grid"``): ``squares_x`` × ``squares_y`` tags of
  ``square_m`` (the black square's edge) ``spacing_m`` apart, ids ``0 ..`` row by row from
  the top left. Corner ids: ``4 * tag_id + k`` with k = 0..3 the tag's top-left, top-right,
  bottom-right, bottom-left corner (OpenCV's order).

The texture is OpenCV's board image (``generateImage``) at ``texture_px_per_m`` with a
white quiet zone of ``quiet_zone_m`` around it. :func:`add_board` puts it on a thin box in a
``mujoco.MjSpec`` (texture on the box's +z face: top towards geom +y, left towards geom -x,
docs/platform.md); :func:`board_pose_estimator` detects the board (``CharucoDetector`` /
``ArucoDetector`` + ``matchImagePoints``) and solves PnP on all its corners.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from simcalib.config.checks import check_in, check_int, check_range, check_that, set_fields

__all__ = ["BOARD_KINDS", "TARGETS", "BoardConfig", "cv_board", "board_image", "board_png",
           "board_corners", "T_geom_board", "BoardPose", "BoardPoseEstimator",
           "board_pose_estimator", "check_target", "board_config", "solve_board_pnp",
           "board_for_target"]

#: Board kinds and their default dictionaries.
BOARD_KINDS = {"charuco": "DICT_5X5_250", "apriltag_grid": "DICT_APRILTAG_36h11"}
#: Values of the ``target`` config key: today's marker walls, or one board.
TARGETS = ("marker_wall",) + tuple(BOARD_KINDS)
#: Thickness of the board's box geom.
BOARD_THICKNESS_M = 0.004


def check_target(value) -> str:
    """``value`` if it is a valid target name, else a ConfigError listing the valid ones."""
    return check_in("target", value, TARGETS)


#: OpenCV's predefined dictionaries and their number of ids (``cv2.aruco.DICT_*``; checked
#: against OpenCV in tests/test_targets_boards.py), so that a config is validated without importing
#: OpenCV.
DICTIONARY_SIZES = {
    **{f"DICT_{b}X{b}_{n}": n for b in (4, 5, 6, 7) for n in (50, 100, 250, 1000)},
    "DICT_ARUCO_ORIGINAL": 1024, "DICT_APRILTAG_16h5": 30, "DICT_APRILTAG_25h9": 35,
    "DICT_APRILTAG_36h10": 2320, "DICT_APRILTAG_36h11": 587, "DICT_ARUCO_MIP_36h12": 250,
}


@dataclass(frozen=True)
class BoardConfig:
    """One calibration board (see the module docstring for its frame and corner ids).

    ``kind``: ``charuco`` | ``apriltag_grid``; ``squares_x`` / ``squares_y``: squares
    (ChArUco) or tags (grid) across / down; ``square_m``: ChArUco square or AprilTag edge;
    ``marker_m``: ChArUco marker edge (< ``square_m``); ``spacing_m``: gap between tags;
    ``dictionary``: ``None`` = the kind's own (``DICT_5X5_250`` / ``DICT_APRILTAG_36h11``);
    ``texture_px_per_m``, ``quiet_zone_m``: the texture. ``wall`` / ``center_m``: where the
    world puts a wall board (``+x``, ``-x``, ``+y``, ``-y``: the wall at that side of the
    room, seen from inside; ``center_m`` = (along the wall to the right, height) of the
    board's centre). Defaults: an 8 x 6 ChArUco of 10 cm squares on the ``+x`` wall at
    1.3 m (where the ``handeye`` wrist camera looks)."""
    kind: str = "charuco"
    squares_x: int = 8
    squares_y: int = 6
    square_m: float = 0.10
    marker_m: float = 0.075
    spacing_m: float = 0.025
    dictionary: str | None = None
    texture_px_per_m: float = 2000.0
    quiet_zone_m: float = 0.05
    wall: str = "+x"
    center_m: tuple = (0.0, 1.3)

    def __post_init__(self):
        check_in("kind", self.kind, sorted(BOARD_KINDS))
        check_in("wall", self.wall, ("+x", "-x", "+y", "-y"))
        dictionary = self.dictionary or BOARD_KINDS[self.kind]
        check_in("dictionary", dictionary, sorted(DICTIONARY_SIZES))
        center = tuple(float(v) for v in np.ravel(np.asarray(self.center_m, dtype=float)))
        check_that(len(center) == 2, "center_m", self.center_m, "(along the wall, height) in m")
        set_fields(
            self, dictionary=dictionary, center_m=center,
            squares_x=check_int("squares_x", self.squares_x, lo=2, hi=40),
            squares_y=check_int("squares_y", self.squares_y, lo=2, hi=40),
            square_m=check_range("square_m", self.square_m, lo=0.005, hi=1.0),
            marker_m=check_range("marker_m", self.marker_m, lo=0.002, hi=1.0),
            spacing_m=check_range("spacing_m", self.spacing_m, lo=0.0, hi=1.0, lo_open=True),
            texture_px_per_m=check_range("texture_px_per_m", self.texture_px_per_m,
                                         lo=200.0, hi=10000.0),
            quiet_zone_m=check_range("quiet_zone_m", self.quiet_zone_m, lo=0.0, hi=1.0))
        if self.kind == "charuco":
            check_that(self.marker_m < self.square_m, "marker_m", self.marker_m,
                       f"< square_m ({self.square_m:g})")
        n_ids = self.n_markers
        have = DICTIONARY_SIZES[dictionary]
        check_that(n_ids <= have, "dictionary", dictionary,
                   f"a dictionary with at least {n_ids} ids (this one has {have})")

    @property
    def n_markers(self) -> int:
        n = self.squares_x * self.squares_y
        return n // 2 if self.kind == "charuco" else n

    @property
    def size_m(self) -> tuple[float, float]:
        """(width, height) of the pattern, quiet zone excluded."""
        if self.kind == "charuco":
            return self.squares_x * self.square_m, self.squares_y * self.square_m
        s, g = self.square_m, self.spacing_m
        return self.squares_x * s + (self.squares_x - 1) * g, \
            self.squares_y * s + (self.squares_y - 1) * g


def board_config(value, key: str = "board") -> BoardConfig:
    """A :class:`BoardConfig` from an instance or a mapping of its fields (unknown keys are
    a ConfigError naming the allowed ones)."""
    if isinstance(value, BoardConfig):
        return value
    from simcalib.errors import ConfigError, did_you_mean  # noqa: PLC0415
    from dataclasses import fields  # noqa: PLC0415
    allowed = [f.name for f in fields(BoardConfig)]
    if not isinstance(value, dict):
        raise ConfigError(f"{key}: expected a mapping of {allowed}; received "
                          f"{type(value).__name__}", key=key)
    for k in value:
        if k not in allowed:
            raise ConfigError(f"{key}: unknown key {k!r}{did_you_mean(k, allowed)}; allowed: "
                              f"{', '.join(allowed)}", key=f"{key}.{k}")
    return BoardConfig(**value)


def board_for_target(value, target: str) -> BoardConfig:
    """The board of a world whose ``target`` is ``target``: ``value`` (instance or mapping)
    with its kind set to the target's (its dictionary too, unless one was chosen)."""
    if isinstance(value, dict) and "kind" not in value and target in BOARD_KINDS:
        value = {**value, "kind": target}
    board = board_config(value)
    if target in BOARD_KINDS and board.kind != target:
        own = board.dictionary == BOARD_KINDS[board.kind]
        board = replace(board, kind=target, dictionary=None if own else board.dictionary)
    return board


def cv_board(board: BoardConfig):
    """The OpenCV board object (``cv2.aruco.CharucoBoard`` / ``cv2.aruco.GridBoard``)."""
    import cv2  # noqa: PLC0415
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, board.dictionary))
    size = (board.squares_x, board.squares_y)
    if board.kind == "charuco":
        return cv2.aruco.CharucoBoard(size, board.square_m, board.marker_m, d)
    return cv2.aruco.GridBoard(size, board.square_m, board.spacing_m, d)


def _pattern_px(board: BoardConfig) -> tuple[int, int]:
    w, h = board.size_m
    return int(round(w * board.texture_px_per_m)), int(round(h * board.texture_px_per_m))


def board_image(board: BoardConfig) -> np.ndarray:
    """``(H, W)`` uint8 texture: OpenCV's board image plus the white quiet zone. Pixel
    ``(u, v)`` (centre at integers) shows board point ``((u - q + 0.5) / ppm, (v - q + 0.5)
    / ppm)`` with ``q`` the quiet zone in pixels."""
    w, h = _pattern_px(board)
    img = cv_board(board).generateImage((w, h), marginSize=0, borderBits=1)
    q = int(round(board.quiet_zone_m * board.texture_px_per_m))
    return np.pad(img, q, mode="constant", constant_values=255)


def board_png(board: BoardConfig) -> bytes:
    """:func:`board_image` as PNG bytes (MuJoCo textures are PNG)."""
    import cv2  # noqa: PLC0415
    ok, buf = cv2.imencode(".png", board_image(board))
    if not ok:
        raise RuntimeError("PNG encoding of the board texture failed")
    return buf.tobytes()


def board_corners(board: BoardConfig) -> tuple[np.ndarray, np.ndarray]:
    """``(ids (N,), points (N, 3))``: every corner of the board in the board frame."""
    if board.kind == "charuco":
        nx, ny = board.squares_x - 1, board.squares_y - 1
        r, c = np.divmod(np.arange(nx * ny), nx)
        pts = np.stack([(c + 1) * board.square_m, (r + 1) * board.square_m,
                        np.zeros(nx * ny)], axis=-1)
        return np.arange(nx * ny, dtype=np.int64), pts
    pitch = board.square_m + board.spacing_m
    r, c = np.divmod(np.arange(board.n_markers), board.squares_x)
    tl = np.stack([c * pitch, r * pitch], axis=-1)                      # (M, 2)
    offs = board.square_m * np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    xy = (tl[:, None, :] + offs[None]).reshape(-1, 2)
    return np.arange(4 * board.n_markers, dtype=np.int64), np.column_stack(
        [xy, np.zeros(len(xy))])


def T_geom_board(board: BoardConfig) -> np.ndarray:
    """Pose of the board frame in its box geom's frame (geom: centre of the box, +z out of
    the textured face towards the viewer, +y = the texture's top)."""
    w, h = board.size_m
    T = np.diag([1.0, -1.0, -1.0, 1.0])
    T[:3, 3] = [-0.5 * w, 0.5 * h, 0.5 * BOARD_THICKNESS_M]
    return T


# ------------------------------------------------------------------------ detection, PnP
@dataclass(frozen=True)
class BoardPose:
    """One image's board pose. ``status``: ``"ok"`` or a drop reason of
    :data:`simcalib.targets.marker_pnp.DROP_REASONS`; ``T_cam_board`` ``(4, 4)`` (``None``
    unless ok);
    ``corner_ids`` ``(N,)`` / ``corners_px`` ``(N, 2)``: the corners of the final fit;
    ``marker_ids`` ``(M,)`` / ``marker_corners_px`` ``(M, 4, 2)``: the board's markers found;
    ``reproj_rmse_px``; ``ambiguity``: refined RMSE of the best rival pose (rotation > 3°
    away) over the best one's (``inf``: no rival)."""
    status: str
    T_cam_board: np.ndarray | None
    corner_ids: np.ndarray
    corners_px: np.ndarray
    marker_ids: np.ndarray
    marker_corners_px: np.ndarray
    reproj_rmse_px: float = float("inf")
    ambiguity: float = float("inf")

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def _no_pose(reason, mids, mc, cids=None, cpx=None, rmse=float("inf")) -> BoardPose:
    cids = np.zeros(0, dtype=np.int64) if cids is None else cids
    cpx = np.zeros((0, 2)) if cpx is None else cpx
    return BoardPose(reason, None, cids, cpx, mids, mc, float(rmse))


def _rvec_tvec_T(rvec, tvec) -> np.ndarray:
    import cv2  # noqa: PLC0415
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3))[0]
    T[:3, 3] = np.asarray(tvec, dtype=np.float64).reshape(3)
    return T


def _point_errors(T: np.ndarray, obj: np.ndarray, img: np.ndarray, K: np.ndarray) -> np.ndarray:
    pc = obj @ T[:3, :3].T + T[:3, 3]
    z = pc[:, 2]
    uv = (pc @ K.T)[:, :2] / np.where(z > 1e-9, z, np.nan)[:, None]
    e = np.linalg.norm(uv - img, axis=-1)
    return np.where(np.isfinite(e), e, 1e6)


def _refined(T0: np.ndarray, obj, img, K) -> np.ndarray:
    import cv2  # noqa: PLC0415
    rvec = cv2.Rodrigues(T0[:3, :3])[0]
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, None, rvec, T0[:3, 3].reshape(3, 1).copy())
    return _rvec_tvec_T(rvec, tvec)


def _rmse(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e ** 2))) if e.size else float("inf")


def _angle_rad(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = 0.5 * (np.trace(Ra.T @ Rb) - 1.0)
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def solve_board_pnp(obj: np.ndarray, img: np.ndarray, K: np.ndarray, *,
                    max_point_reproj_px: float = 2.0) -> tuple:
    """Planar PnP on all board corners: both ``SOLVEPNP_IPPE`` solutions refined with
    ``solvePnPRefineLM``, the better kept; corners off by more than
    ``max_point_reproj_px`` dropped (worst first) and the fit redone. Returns ``(T_cam_board,
    rmse_px, ambiguity, used mask)``; ambiguity = rival RMSE / best RMSE (``inf``: none)."""
    import cv2  # noqa: PLC0415
    obj = np.ascontiguousarray(obj, dtype=np.float64)
    img = np.ascontiguousarray(img, dtype=np.float64)
    _, rvecs, tvecs, _ = cv2.solvePnPGeneric(obj, img, K, None, flags=cv2.SOLVEPNP_IPPE)
    cands = [_refined(_rvec_tvec_T(r, t), obj, img, K) for r, t in zip(rvecs, tvecs)]
    use = np.ones(len(obj), dtype=bool)
    errs = [_rmse(_point_errors(T, obj, img, K)) for T in cands]
    order = np.argsort(errs)
    best = cands[order[0]]
    for _ in range(len(obj)):
        e = _point_errors(best, obj, img, K)
        bad = np.flatnonzero(use & (e > max_point_reproj_px))
        if bad.size == 0 or use.sum() - 1 < 4:
            break
        use[bad[np.argmax(e[bad])]] = False
        best = _refined(best, obj[use], img[use], K)
    rmse = _rmse(_point_errors(best, obj[use], img[use], K))
    ambiguity = float("inf")
    for i in order[1:]:
        if _angle_rad(cands[i][:3, :3], best[:3, :3]) > np.deg2rad(3.0):
            rival = _refined(cands[i], obj[use], img[use], K)
            r_rmse = _rmse(_point_errors(rival, obj[use], img[use], K))
            ambiguity = r_rmse / max(rmse, 1e-12)
    return best, rmse, ambiguity, use


class BoardPoseEstimator:
    """Detects one board and solves its pose (picklable; OpenCV objects rebuilt per
    process). ``detector_settings``: :class:`simcalib.targets.markers.DetectorSettings` fields
    except the dictionary (the board's own); the gates: at least ``min_corners`` corners,
    RMSE <= ``max_reproj_rmse_px``, ambiguity ratio >= ``ambiguity_ratio``."""

    def __init__(self, board: BoardConfig, *, corner_refinement: str = "subpix",
                 edge_refinement: bool = True, min_corners: int = 6,
                 max_reproj_rmse_px: float = 1.0, max_point_reproj_px: float = 2.0,
                 ambiguity_ratio: float = 2.0):
        from simcalib.targets.markers import DetectorSettings  # noqa: PLC0415
        self.board = board
        self.settings = DetectorSettings(dictionary=board.dictionary,
                                         corner_refinement=corner_refinement,
                                         edge_refinement=edge_refinement)
        self.min_corners = check_int("min_corners", min_corners, lo=4)
        self.max_reproj_rmse_px = float(max_reproj_rmse_px)
        self.max_point_reproj_px = float(max_point_reproj_px)
        self.ambiguity_ratio = float(ambiguity_ratio)
        self.ids, self.points = board_corners(board)
        self._cv = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_cv"] = None
        return state

    def _objects(self):
        if self._cv is None:
            import cv2  # noqa: PLC0415
            from simcalib.targets.markers import make_detector  # noqa: PLC0415
            det = make_detector(self.settings)
            cvb = cv_board(self.board)
            charuco = None
            if self.board.kind == "charuco":
                charuco = cv2.aruco.CharucoDetector(cvb, cv2.aruco.CharucoParameters(),
                                                    det.getDetectorParameters())
            self._cv = (det, cvb, charuco)
        return self._cv

    def detect(self, gray: np.ndarray) -> tuple:
        """``(marker ids (M,), marker corners (M, 4, 2), corner ids (N,), corners (N, 2))``."""
        from simcalib.targets.markers import detect_markers  # noqa: PLC0415
        det, _cvb, charuco = self._objects()
        d = detect_markers(gray, det, self.settings)
        keep = d.ids < self.board.n_markers
        mids, mc = d.ids[keep], d.corners_px[keep]
        if mids.size == 0:
            return mids, mc, np.zeros(0, dtype=np.int64), np.zeros((0, 2))
        if charuco is not None:
            cc, ci, _, _ = charuco.detectBoard(
                gray, markerCorners=tuple(m.reshape(1, 4, 2).astype(np.float32) for m in mc),
                markerIds=mids.astype(np.int32).reshape(-1, 1))
            if ci is None or len(ci) == 0:
                return mids, mc, np.zeros(0, dtype=np.int64), np.zeros((0, 2))
            return mids, mc, np.ravel(ci).astype(np.int64), np.asarray(
                cc, dtype=np.float64).reshape(-1, 2)
        cids = (4 * mids[:, None] + np.arange(4)[None]).ravel()
        return mids, mc, cids, mc.reshape(-1, 2)

    def __call__(self, image, K, undistort=None) -> BoardPose:
        """Board pose in one uint8 grey/RGB image with camera matrix ``K``. ``undistort``:
        optional function mapping ``(N, 2)`` pixels to undistorted pixels (the
        estimator's calibration) before PnP."""
        from simcalib.targets.markers import _as_gray  # noqa: PLC0415
        gray = _as_gray(image)
        K = np.asarray(K, dtype=np.float64)
        mids, mc, cids, cpx = self.detect(gray)
        if mids.size == 0:
            return _no_pose("no_markers", mids, mc)
        if cids.size < self.min_corners:
            return _no_pose("too_few_markers", mids, mc, cids, cpx)
        img = undistort(cpx) if undistort is not None else cpx
        try:
            T, rmse, amb, use = solve_board_pnp(self.points[cids], img, K,
                                                max_point_reproj_px=self.max_point_reproj_px)
        except Exception:  # noqa: BLE001 - OpenCV raises cv2.error on degenerate input
            return _no_pose("pnp_failed", mids, mc, cids, cpx)
        if use.sum() < self.min_corners:
            return _no_pose("too_few_markers", mids, mc, cids[use], cpx[use], rmse)
        if rmse > self.max_reproj_rmse_px:
            return _no_pose("reprojection_error", mids, mc, cids[use], cpx[use], rmse)
        if amb < self.ambiguity_ratio:
            return BoardPose("ambiguous", None, cids[use], cpx[use], mids, mc, rmse, amb)
        return BoardPose("ok", T, cids[use], cpx[use], mids, mc, rmse, amb)


def board_pose_estimator(board: BoardConfig, **settings) -> BoardPoseEstimator:
    """A :class:`BoardPoseEstimator` for ``board`` (``settings``: its keyword options)."""
    return BoardPoseEstimator(board_config(board), **settings)
