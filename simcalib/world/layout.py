"""Layout of the room: where the arm stands, the ArUco marker field, and marker
visibility (pure numpy).

Marker frame (simcalib/targets/markers.py): origin at the marker centre on its printed face, +z out
of the face (into the room), +y up in the upright marker image, +x to its right. In MuJoCo
each marker is a thin box geom whose frame *is* the marker frame shifted by half the
thickness along -z; the marker texture on the box's +z face appears with its top towards
geom +y and its left towards geom -x (docs/platform.md), i.e. no extra rotation.

Walls: markers stand upright (marker +y = world +z) with +z along the wall's inward normal.
Floor: +z = world +z, +y = world +y. Ceiling: +z = world -z, +y = world +y.
Ids run 0, 1, ... over the walls (+x, +y, -x, -y), then the floor, then the ceiling,
each surface row by row from the bottom-left as seen from inside the room.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import distort_pixels, invert_transform, project_points as _project
from simcalib.targets.markers import MarkerField, marker_corners_local
from simcalib.streams import CameraIntrinsics

__all__ = ["ARM_HOME_OFFSET_M", "ARM_BASE_TO_WALL_M", "arm_base_position", "marker_layout", "dictionary_size", "marker_cells", "project_points",
           "visible_markers", "marker_views", "MARKER_SURFACE_OFFSET_M"]

#: Printed face of a marker sits this far in front of its wall/floor/ceiling surface.
MARKER_SURFACE_OFFSET_M = 0.002


#: Arm home: the flange frame equals the rig frame looking along world +x (flange z = +x,
#: y = -z, x = -y), ``ARM_HOME_OFFSET_M`` from the pedestal foot (0.55 m in front of the
#: base axis, 0.30 m above the shoulder).
ARM_HOME_OFFSET_M = np.array([0.55, 0.0, 0.6 + 0.1625 + 0.30])
#: Distance from the arm's base axis to the +x wall (the rig looks at that wall).
ARM_BASE_TO_WALL_M = 1.75


def arm_base_position(room_size_m) -> np.ndarray:
    """World position of the arm's pedestal foot for a room of inner size ``room_size_m``."""
    return np.array([0.5 * room_size_m[0] - ARM_BASE_TO_WALL_M, 0.0, 0.0])

def _cv2_dictionary(name: str):
    import cv2
    if not hasattr(cv2.aruco, name):
        valid = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        raise ValueError(f"unknown ArUco dictionary {name!r}; valid: {valid}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def dictionary_size(name: str) -> int:
    """Number of marker ids in an OpenCV predefined dictionary."""
    return int(_cv2_dictionary(name).bytesList.shape[0])


def marker_cells(name: str) -> int:
    """Cells across a marker image with its 1-cell black border (e.g. 6 for 4x4)."""
    return int(_cv2_dictionary(name).markerSize) + 2


def _grid(length: float, side: float, pitch: float, margin: float) -> np.ndarray:
    """Centred 1D marker centres along a surface of ``length`` (edge-to-edge)."""
    usable = length - 2.0 * margin - side * 8.0 / 6.0
    if usable < 0:
        return np.zeros(0)
    n = int(np.floor(usable / pitch + 1e-9)) + 1
    return (np.arange(n) - 0.5 * (n - 1)) * pitch


def _frames(R: np.ndarray, centres: np.ndarray) -> np.ndarray:
    T = np.zeros((len(centres), 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = centres
    T[:, 3, 3] = 1.0
    return T


def marker_layout(room, markers) -> MarkerField:
    """The :class:`MarkerField` for a ``RoomConfig`` and a ``MarkerFieldConfig``.

    Raises ``ValueError`` if the dictionary holds fewer ids than the layout needs (naming
    both numbers and what to change) or if no marker fits."""
    sx, sy, sz = room.size_m
    side, pitch, margin = markers.side_m, markers.pitch_m, markers.margin_m
    eps = MARKER_SURFACE_OFFSET_M
    up = np.array([0.0, 0.0, 1.0])
    blocks = []
    if "walls" in markers.surfaces:
        heights = _grid(sz, side, pitch, margin) + 0.5 * sz
        # (inward normal, wall coordinate of the face, half-length along the wall)
        for normal, length in (((-1.0, 0.0, 0.0), sy), ((0.0, -1.0, 0.0), sx),
                               ((1.0, 0.0, 0.0), sy), ((0.0, 1.0, 0.0), sx)):
            n = np.array(normal)
            x_m = np.cross(up, n)                       # right, seen from inside the room
            R = np.column_stack([x_m, up, n])
            face = -n * (0.5 * np.array([sx, sy, 0.0])) + n * eps    # point on the face
            u = _grid(length, side, pitch, margin)
            uu, hh = np.meshgrid(u, heights)            # rows bottom to top
            c = face[None, :] + uu.reshape(-1, 1) * x_m + hh.reshape(-1, 1) * up
            blocks.append(_frames(R, c))
    for surface, z, R in (("floor", eps, np.eye(3)),
                          ("ceiling", sz - eps, np.diag([-1.0, 1.0, -1.0]))):
        if surface in markers.surfaces:
            ux = _grid(sx, side, pitch, margin)
            uy = _grid(sy, side, pitch, margin)
            xx, yy = np.meshgrid(ux, uy)
            c = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, z)], axis=-1)
            blocks.append(_frames(R, c))
    T = np.concatenate(blocks, axis=0) if blocks else np.zeros((0, 4, 4))
    if T.shape[0] == 0:
        raise ValueError(f"no marker fits: room {room.size_m} m, side {side} m, pitch {pitch} "
                         f"m, margin {margin} m; reduce side/margin or enlarge the room")
    capacity = dictionary_size(markers.dictionary)
    if T.shape[0] > capacity:
        raise ValueError(f"the marker layout needs {T.shape[0]} ids but {markers.dictionary} "
                         f"holds {capacity}; increase pitch_m (now {pitch}), use fewer "
                         "surfaces, or a larger dictionary (e.g. DICT_4X4_1000)")
    return MarkerField(dictionary=markers.dictionary, ids=np.arange(T.shape[0]),
                       side_m=float(side), T_world_marker=T)


# ------------------------------------------------------------------------ visibility
def project_points(T_world_cam: np.ndarray, intr: CameraIntrinsics, p_world: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Pinhole projection (OpenCV frames, no distortion), batched
    (:func:`simcalib.geometry.project_points` with a camera pose and intrinsics).

    ``T_world_cam`` ``(F, 4, 4)``, ``p_world`` ``(..., 3)`` -> pixels ``(F, ..., 2)`` and
    depths ``(F, ...)``."""
    return _project(invert_transform(np.asarray(T_world_cam, dtype=np.float64)), p_world,
                    intr.K)


def visible_markers(field: MarkerField, T_world_cam: np.ndarray, intr: CameraIntrinsics, *,
                    min_side_px: float = 20.0, max_view_angle_deg: float = 70.0,
                    border_px: float = 2.0, min_depth_m: float = 0.05,
                    distortion=None) -> np.ndarray:
    """``(F, M)`` bool: marker fully inside the image (all four corners at least
    ``border_px`` from the edge, in front of the camera), facing it within
    ``max_view_angle_deg`` of its normal, and with its shortest projected edge at least
    ``min_side_px`` pixels. Occlusion by the platform is not modelled. ``distortion``
    (k1, k2, p1, p2, k3; default none): the image is the lens's distorted one
    (:func:`simcalib.geometry.distort_pixels`): a barrel lens shows markers beyond the
    pinhole image's edge, and shrinks them there."""
    return marker_views(field, T_world_cam, intr, min_side_px=min_side_px,
                        max_view_angle_deg=max_view_angle_deg, border_px=border_px,
                        min_depth_m=min_depth_m, distortion=distortion)[0]


def marker_views(field: MarkerField, T_world_cam: np.ndarray, intr: CameraIntrinsics, *,
                 min_side_px: float = 20.0, max_view_angle_deg: float = 70.0,
                 border_px: float = 2.0, min_depth_m: float = 0.05,
                 distortion=None) -> tuple[np.ndarray, np.ndarray]:
    """``(visible (F, M) bool, shortest projected edge (F, M) px)``: :func:`visible_markers`
    with the edge lengths its size test used (in the distorted image with ``distortion``)."""
    T = np.asarray(T_world_cam, dtype=np.float64)
    if T.ndim == 2:
        T = T[None]
    corners = field.corners_world()                             # (M, 4, 3)
    uv, z = project_points(T, intr, corners)                    # (F, M, 4, 2), (F, M, 4)
    ok = z > min_depth_m
    if distortion is not None and np.any(np.asarray(distortion, dtype=np.float64) != 0):
        uv, one_to_one = distort_pixels(uv, intr.K, distortion)
        ok &= one_to_one
    inside = ((uv[..., 0] >= border_px) & (uv[..., 0] <= intr.width - 1 - border_px)
              & (uv[..., 1] >= border_px) & (uv[..., 1] <= intr.height - 1 - border_px)
              & ok).all(axis=-1)
    centre = field.T_world_marker[:, :3, 3]
    normal = field.T_world_marker[:, :3, 2]
    to_cam = T[:, None, :3, 3] - centre[None]                   # (F, M, 3)
    dist = np.linalg.norm(to_cam, axis=-1)
    cos = np.einsum("fmi,mi->fm", to_cam, normal) / np.maximum(dist, 1e-12)
    facing = cos >= np.cos(np.deg2rad(max_view_angle_deg))
    edges = np.linalg.norm(uv - np.roll(uv, -1, axis=-2), axis=-1).min(axis=-1)
    return inside & facing & (edges >= min_side_px), edges


