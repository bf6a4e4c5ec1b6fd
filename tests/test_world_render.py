"""The marker field MuJoCo renders is the MarkerField the world reports (ids, corner order,
positions): detected corners match the projection of the known map to a fraction of a
pixel. Skips only when no offscreen rendering backend works."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from simcalib.geometry import invert_transform
from simcalib.world import WorldConfig, build_world, visible_markers
from simcalib.world.layout import project_points

mujoco = pytest.importorskip("mujoco")
cv2 = pytest.importorskip("cv2")


def _renderer(model, h, w):
    try:
        return mujoco.Renderer(model, h, w)
    except Exception as exc:  # no EGL/OSMesa context on this machine
        pytest.skip(f"no offscreen rendering backend ({os.environ.get('MUJOCO_GL')}): {exc}")


@pytest.mark.slow
@pytest.mark.parametrize("platform, path, frames", [("cart", "planar", (0, 120)),
                                                     ("arm", "3d", (0, 70))])
def test_rendered_markers_match_known_map(platform, path, frames):
    w = build_world(WorldConfig(platform=platform, path=path), np.random.default_rng(0))
    m = w.model
    data = mujoco.MjData(m)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    det = cv2.aruco.ArucoDetector(
        cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, w.marker_field.dictionary)), params)
    corners_world = w.marker_field.corners_world()
    with _renderer(m, 480, 640) as r:
        for cam in w.camera_names:
            fr = w.frames(cam)
            intr = w.intrinsics[cam]
            for k in frames:
                if m.nq:
                    data.qpos[:] = fr.qpos[k]
                if m.nmocap:
                    data.mocap_pos[:] = fr.mocap_pos[k]
                    data.mocap_quat[:] = fr.mocap_quat_wxyz[k]
                mujoco.mj_forward(m, data)
                r.update_scene(data, camera=cam)
                r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
                gray = cv2.cvtColor(r.render(), cv2.COLOR_RGB2GRAY)
                corners, ids, _ = det.detectMarkers(gray)
                assert ids is not None
                ids = np.ravel(ids)
                vis = np.flatnonzero(visible_markers(w.marker_field, fr.T_world_cam[k], intr)[0])
                # nearly every marker predicted fully visible is detected, nothing spurious
                assert len(set(vis) - set(ids)) <= max(1, len(vis) // 10)
                assert set(ids) <= set(w.marker_field.ids)
                uv, _ = project_points(fr.T_world_cam[k][None], intr, corners_world[ids])
                err = np.linalg.norm(np.concatenate(corners).reshape(-1, 4, 2) - uv[0], axis=-1)
                assert np.median(err) < 0.3 and err.max() < 1.5, (cam, k, err.max())
