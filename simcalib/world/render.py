"""The MuJoCo camera renderer: :class:`CameraRenderer` renders a named model camera from
raw MuJoCo state (``qpos``, ``mocap_pos``, ``mocap_quat_wxyz``) with shadows off (shadow
edges move marker corners by pixels) and, by default, no multisampling (``offsamples=0``:
~3x faster, and detected corners are as accurate; docs/vision.md). It renders a private
copy of the model, so the caller's model is never modified. The one conversion of MuJoCo
camera frames to OpenCV poses (:func:`T_world_cv_from_mujoco`) is here too.

Rendering is all in ``simcalib/world/render*.py``: the OpenGL backend
(:mod:`simcalib.world.render_backend`), this renderer, and many frames in worker processes
(:mod:`simcalib.world.render_map`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import transform_from_rotation_translation
from simcalib.world.render_backend import (RenderBackendError, backend_error_message,
                                           import_mujoco, loaded_backend, mark_unusable)

__all__ = ["CameraRenderer", "MJ_FROM_CV", "RenderSettings", "T_world_cv_from_mujoco",
           "model_from_bytes", "model_to_bytes"]

#: OpenCV camera frame <-> MuJoCo camera frame (its own inverse): R_mj = R_cv @ MJ_FROM_CV.
MJ_FROM_CV = np.diag([1.0, -1.0, -1.0])


def T_world_cv_from_mujoco(cam_xpos: np.ndarray, cam_xmat: np.ndarray) -> np.ndarray:
    """``(..., 4, 4)`` pose of a camera's OpenCV frame (x right, y down, z forward) in the
    world from MuJoCo's ``cam_xpos`` ``(..., 3)`` and ``cam_xmat`` ``(..., 9)`` or
    ``(..., 3, 3)`` (MuJoCo cameras look along -z, +y up) — the one place this conversion
    is written."""
    R = np.asarray(cam_xmat, dtype=np.float64)
    R = R.reshape(R.shape[:-1] + (3, 3)) if R.shape[-1] == 9 else R
    return transform_from_rotation_translation(R @ MJ_FROM_CV,
                                               np.asarray(cam_xpos, dtype=np.float64))


# ----------------------------------------------------------------------------- model I/O
def model_to_bytes(model) -> bytes:
    """Serialise a compiled ``MjModel`` (MuJoCo binary format) for worker processes."""
    import pickle  # noqa: PLC0415
    return pickle.dumps(model, protocol=pickle.HIGHEST_PROTOCOL)


def model_from_bytes(blob: bytes):
    import pickle  # noqa: PLC0415
    import_mujoco()
    return pickle.loads(blob)


# ------------------------------------------------------------------------------ renderer
@dataclass(frozen=True)
class RenderSettings:
    """How camera images are rendered.

    ``width``/``height``: image size in pixels (the offscreen buffer is enlarged to fit).
    ``fovy_deg``: per-camera vertical field of view overriding the model's (``{}``: keep).
    ``msaa_samples``: multisampling (MuJoCo ``offsamples``); 0 is fastest.
    ``shadows``: MuJoCo shadow mapping (off: shadow edges corrupt marker corners).
    ``coarse_meshes``: tessellate primitive geoms coarsely (``numslices`` 8, ``numstacks``
    4, ``numquads`` 1; ~30 % faster renders of the room/arm, marker corners unchanged —
    textures are mapped per pixel, docs/vision.md); ``False`` keeps the model's quality.
    """
    width: int = 640
    height: int = 480
    fovy_deg: dict = field(default_factory=dict)
    msaa_samples: int = 0
    shadows: bool = False
    coarse_meshes: bool = True

    def __post_init__(self):
        from simcalib.config.checks import check_bool, check_int, check_range, fail, set_fields
        if not isinstance(self.fovy_deg, dict):
            raise fail("fovy_deg", self.fovy_deg, "a dict camera -> degrees", type_error=True)
        set_fields(
            self,
            width=check_int("width", self.width, lo=8, hi=8192),
            height=check_int("height", self.height, lo=8, hi=8192),
            msaa_samples=check_int("msaa_samples", self.msaa_samples, lo=0, hi=16),
            shadows=check_bool("shadows", self.shadows),
            coarse_meshes=check_bool("coarse_meshes", self.coarse_meshes),
            fovy_deg={cam: check_range(f"fovy_deg[{cam!r}]", v, lo=0.0, hi=180.0,
                                       lo_open=True, hi_open=True)
                      for cam, v in self.fovy_deg.items()})


class CameraRenderer:
    """Offscreen renderer of a model's cameras from raw MuJoCo state (in this process).

    Use as a context manager (or call :meth:`close`). The model is copied and the copy
    adjusted to ``settings`` (buffer size, MSAA, fovy overrides); shadows are switched off
    in the scene unless ``settings.shadows``.
    """

    def __init__(self, model, settings: RenderSettings | None = None):
        settings = settings or RenderSettings()
        mujoco = import_mujoco()
        if not isinstance(model, mujoco.MjModel):
            raise TypeError(f"model must be a compiled mujoco.MjModel; received "
                            f"{type(model).__name__}")
        self.settings = settings
        m = model_from_bytes(model_to_bytes(model))  # private copy: never mutate the caller's
        m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), settings.width)
        m.vis.global_.offheight = max(int(m.vis.global_.offheight), settings.height)
        m.vis.quality.offsamples = int(settings.msaa_samples)
        if settings.coarse_meshes:
            m.vis.quality.numslices = min(int(m.vis.quality.numslices), 8)
            m.vis.quality.numstacks = min(int(m.vis.quality.numstacks), 4)
            m.vis.quality.numquads = 1
        for cam, fovy in settings.fovy_deg.items():
            cid = self._camera_id(m, cam)
            if np.any(np.asarray(m.cam_sensorsize[cid]) > 0):
                raise ValueError(f"camera {cam!r} is defined by sensorsize/focal length, which "
                                 "makes MuJoCo ignore fovy; a fovy override is not allowed")
            m.cam_fovy[cid] = float(fovy)
        self.model = m
        self.data = mujoco.MjData(m)
        self._mujoco = mujoco
        try:
            self._renderer = mujoco.Renderer(m, settings.height, settings.width)
        except Exception as exc:  # noqa: BLE001  (GL failures surface as many types)
            reason = f"{type(exc).__name__}: {exc}"
            mark_unusable(reason)
            raise RenderBackendError(backend_error_message({loaded_backend(): reason})) from exc
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = bool(settings.shadows)
        self._cam_ids: dict[str, int] = {}
        self._light0 = (np.array(m.light_diffuse, copy=True), np.array(m.light_ambient,
                        copy=True), np.array(m.light_dir, copy=True),
                        np.array(m.vis.headlight.diffuse, copy=True),
                        np.array(m.vis.headlight.ambient, copy=True))
        self._light_now = (1.0, 0.0)

    def set_light(self, scale: float = 1.0, yaw_rad: float = 0.0) -> None:
        """Scale every light's intensity (and the headlight's) by ``scale`` and turn the
        model lights' directions by ``yaw_rad`` about the world z axis (1, 0 restores)."""
        if (float(scale), float(yaw_rad)) == self._light_now:
            return
        m = self.model
        diffuse, ambient, direction, h_diffuse, h_ambient = self._light0
        m.light_diffuse[:] = np.clip(diffuse * scale, 0.0, 1.0)
        m.light_ambient[:] = np.clip(ambient * scale, 0.0, 1.0)
        c, s_ = np.cos(yaw_rad), np.sin(yaw_rad)
        Rz = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
        m.light_dir[:] = direction @ Rz.T
        m.vis.headlight.diffuse[:] = np.clip(h_diffuse * scale, 0.0, 1.0)
        m.vis.headlight.ambient[:] = np.clip(h_ambient * scale, 0.0, 1.0)
        self._light_now = (float(scale), float(yaw_rad))
        self._mujoco.mj_camlight(m, self.data)

    def occluded(self, camera: str, points_world: np.ndarray, tol_m: float = 0.005
                 ) -> np.ndarray:
        """``(N,)`` bool: is the straight line from the camera to each world point blocked
        by a geom (robot, cart, ...) more than ``tol_m`` before the point? Uses the current
        state; geoms of the camera's own body are ignored."""
        pts = np.asarray(points_world, dtype=np.float64).reshape(-1, 3)
        if pts.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        i = self.camera_id(camera)
        p0 = np.array(self.data.cam_xpos[i], dtype=np.float64)
        vec = pts - p0
        length = np.linalg.norm(vec, axis=1)
        unit = np.ascontiguousarray(vec / np.maximum(length, 1e-12)[:, None])
        n = pts.shape[0]
        geomid = np.zeros(n, dtype=np.int32)
        dist = np.zeros(n, dtype=np.float64)
        body = int(self.model.cam_bodyid[i])  # the world body (0) holds the room: keep it
        self._mujoco.mj_multiRay(self.model, self.data, p0, unit.ravel(), None, 1,
                                 body if body > 0 else -1, geomid, dist, None, n,
                                 float(length.max() + 1.0))
        return (dist >= 0) & (dist < length - tol_m)

    @staticmethod
    def _camera_id(m, camera: str) -> int:
        import mujoco  # noqa: PLC0415
        cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, str(camera))
        if cid < 0:
            names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(m.ncam)]
            raise ValueError(f"camera {camera!r} is not in the model; cameras: {names}")
        return cid

    def camera_id(self, camera: str) -> int:
        if camera not in self._cam_ids:
            self._cam_ids[camera] = self._camera_id(self.model, camera)
        return self._cam_ids[camera]

    def set_state(self, qpos=None, mocap_pos=None, mocap_quat_wxyz=None) -> None:
        """Load raw MuJoCo state and update kinematics (no dynamics step)."""
        m, d, mujoco = self.model, self.data, self._mujoco
        if qpos is not None:
            qpos = np.asarray(qpos, dtype=np.float64)
            if qpos.shape != (m.nq,):
                raise ValueError(f"qpos must have shape ({m.nq},); received {qpos.shape}")
            d.qpos[:] = qpos
        if mocap_pos is not None and m.nmocap:
            mocap_pos = np.asarray(mocap_pos, dtype=np.float64)
            if mocap_pos.shape != (m.nmocap, 3):
                raise ValueError(f"mocap_pos must have shape ({m.nmocap}, 3); "
                                 f"received {mocap_pos.shape}")
            d.mocap_pos[:] = mocap_pos
        if mocap_quat_wxyz is not None and m.nmocap:
            q = np.asarray(mocap_quat_wxyz, dtype=np.float64)
            if q.shape != (m.nmocap, 4):
                raise ValueError(f"mocap_quat_wxyz must have shape ({m.nmocap}, 4); "
                                 f"received {q.shape}")
            d.mocap_quat[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_camlight(m, d)

    def T_world_cam(self, camera: str) -> np.ndarray:
        """Pose of the camera's OpenCV frame (x right, y down, z forward) in the world,
        from the current state (:func:`T_world_cv_from_mujoco`)."""
        i = self.camera_id(camera)
        return T_world_cv_from_mujoco(self.data.cam_xpos[i], self.data.cam_xmat[i])

    def render(self, camera: str, qpos=None, mocap_pos=None, mocap_quat_wxyz=None
               ) -> np.ndarray:
        """``(H, W, 3)`` uint8 RGB image (top row first) of ``camera`` at the given state."""
        self.set_state(qpos, mocap_pos, mocap_quat_wxyz)
        self._renderer.update_scene(self.data, camera=self.camera_id(camera))
        self._renderer.scene.flags[self._mujoco.mjtRndFlag.mjRND_SHADOW] = bool(
            self.settings.shadows)
        return self._renderer.render()

    def close(self) -> None:
        r = getattr(self, "_renderer", None)
        if r is not None:
            r.close()
            self._renderer = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):  # best effort; explicit close() is preferred
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass
