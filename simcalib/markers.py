"""All OpenCV ArUco marker code: dictionary, marker images, detection, PnP.

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

__all__ = ["DICTIONARY", "MarkerField", "marker_corners_local", "marker_image", "marker_png"]

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
