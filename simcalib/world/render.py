"""ALL MuJoCo offscreen rendering of simcalib: backend selection, camera renderer, workers.

Backend: MuJoCo reads ``MUJOCO_GL`` once, at import. No simcalib module sets it at import
time; :func:`import_mujoco` (the one way simcalib imports mujoco) lets
:func:`select_backend` decide once, when MuJoCo is first needed: unset -> ``egl``,
``osmesa`` without libOSMesa -> ``egl`` with a warning naming the package, an unknown
value -> :class:`RenderBackendError` listing the valid ones. If the chosen backend cannot
create an OpenGL context, ``egl`` then ``osmesa`` are probed in fresh interpreters and a
working one is used in worker processes; if none works, :class:`RenderBackendError`
names the Debian packages to install.

Renderer: :class:`CameraRenderer` renders a named model camera from raw MuJoCo state
(``qpos``, ``mocap_pos``, ``mocap_quat_wxyz``) with shadows off (shadow edges move marker
corners by pixels) and, by default, no multisampling (``offsamples=0``: ~3x faster, and
detected corners are as accurate; docs/vision.md). It renders a private copy of the model,
so the caller's model is never modified.

Parallel: :func:`render_map` renders many frames in worker processes
(:func:`simcalib.parallel.worker_pool`: Ctrl-C stops them quietly and returns the frames
done in :class:`RenderInterrupted`; ``progress`` reports frames as they finish) and
applies a picklable per-frame function there (so only small results travel back). Results are
returned in job order and do not depend on the worker count: a job carries everything its
frame needs (state, seed key), and rendering the same state gives the same pixels.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

__all__ = [
    "MJ_FROM_CV", "T_world_cv_from_mujoco",
    "DEBIAN_PACKAGES",
    "FrameJob",
    "FrameTiming",
    "RenderBackendError",
    "RenderSettings",
    "CameraRenderer",
    "RenderInterrupted",
    "VALID_BACKENDS",
    "check_progress",
    "available_backend",
    "import_mujoco",
    "select_backend",
    "backend_error_message",
    "loaded_backend",
    "model_to_bytes",
    "model_from_bytes",
    "render_map",
]

#: Debian/Ubuntu packages each backend needs (docs/platform.md).
DEBIAN_PACKAGES = {
    "egl": "libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri",
    "osmesa": "libosmesa6",
}
_BACKENDS = ("egl", "osmesa")


#: No usable OpenGL backend for MuJoCo offscreen rendering (CLI exit code 4); the
#: project-wide :class:`simcalib.errors.BackendError`, kept under its old name.
from simcalib.errors import BackendError as RenderBackendError  # noqa: E402
from simcalib.geometry import transform_from_rotation_translation  # noqa: E402

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


def backend_error_message(failures: dict[str, str]) -> str:
    """The error text when every backend failed: what was tried, why, what to install."""
    tried = "; ".join(f"MUJOCO_GL={name}: {why}" for name, why in failures.items()) or "none"
    return (
        "MuJoCo offscreen rendering is unavailable: no OpenGL backend could create a context "
        f"(tried {tried}). Install the Debian/Ubuntu packages for EGL "
        f"(`apt-get install {DEBIAN_PACKAGES['egl']}`, renders on the CPU through Mesa "
        f"llvmpipe, no display or GPU needed) or for OSMesa (`apt-get install "
        f"{DEBIAN_PACKAGES['osmesa']}`), then run again; you may force one with "
        "MUJOCO_GL=egl or MUJOCO_GL=osmesa set before Python starts.")


#: Values of ``MUJOCO_GL`` simcalib accepts on Linux, with what each needs.
VALID_BACKENDS = {
    "egl": "headless OpenGL through EGL (Mesa llvmpipe on the CPU; the default)",
    "osmesa": "headless software OpenGL (needs libOSMesa: apt-get install libosmesa6)",
    "glfw": "a window-system context (needs a display)",
    "glx": "X11 GLX context (needs a display)",
}

_DECISION: dict[str, str] = {}


def _osmesa_available() -> bool:
    import ctypes.util  # noqa: PLC0415
    return bool(ctypes.util.find_library("OSMesa")) or any(
        os.path.exists(os.path.join(d, "libOSMesa.so.8"))
        for d in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib"))


def select_backend() -> str:
    """Decide the OpenGL backend once, before mujoco is imported, and return it.

    Reads ``MUJOCO_GL``: unset or empty -> ``egl``; ``osmesa`` without libOSMesa -> ``egl``
    with a warning naming the package to install; a value MuJoCo does not know raises
    :class:`RenderBackendError` listing the valid values (instead of MuJoCo's import-time
    ``RuntimeError``). Once mujoco is imported its backend is fixed; this then returns the
    value it was imported with. Called by :func:`import_mujoco`, i.e. when rendering (or any
    MuJoCo use) is first needed — no simcalib module sets ``MUJOCO_GL`` at import time.
    """
    if "backend" in _DECISION:
        return _DECISION["backend"]
    raw = os.environ.get("MUJOCO_GL")
    value = (raw or "").strip().lower()
    if "mujoco" in sys.modules:  # somebody imported mujoco first: its choice stands
        _DECISION["backend"] = value or "glfw"
        return _DECISION["backend"]
    if value in ("", "enable", "enabled", "on", "true", "1"):
        value = "egl"
    elif value in ("disable", "disabled", "off", "false", "0"):
        raise RenderBackendError(
            f"MUJOCO_GL={raw!r} disables OpenGL, but simcalib needs offscreen rendering; "
            f"unset it (simcalib then uses egl) or set one of {sorted(VALID_BACKENDS)}")
    elif value not in VALID_BACKENDS:
        valid = "; ".join(f"{k}: {v}" for k, v in VALID_BACKENDS.items())
        raise RenderBackendError(
            f"MUJOCO_GL={raw!r} is not a valid MuJoCo rendering backend. Valid values: "
            f"{valid}. Unset it to use egl.")
    elif value == "osmesa" and not _osmesa_available():
        warnings.warn(
            "MUJOCO_GL=osmesa but libOSMesa is not installed (Debian/Ubuntu: apt-get install "
            f"{DEBIAN_PACKAGES['osmesa']}); falling back to MUJOCO_GL=egl", RuntimeWarning,
            stacklevel=2)
        value = "egl"
    os.environ["MUJOCO_GL"] = value
    if value == "egl":
        os.environ["PYOPENGL_PLATFORM"] = "egl"
    elif value == "osmesa":
        os.environ["PYOPENGL_PLATFORM"] = "osmesa"
    _DECISION["backend"] = value
    return value


def import_mujoco():
    """``import mujoco`` after :func:`select_backend` has decided ``MUJOCO_GL``: the one
    way simcalib modules import mujoco."""
    select_backend()
    import mujoco  # noqa: PLC0415  (heavy import kept local)
    return mujoco


_ensure_env_default = select_backend  # old name kept for callers inside this module
_import_mujoco = import_mujoco


def loaded_backend() -> str:
    """The OpenGL backend the imported mujoco actually uses (``egl``, ``osmesa``, ``glfw``,
    or ``none``); mujoco picks it once, at import, from ``MUJOCO_GL``."""
    mujoco = _import_mujoco()
    cls = getattr(mujoco, "GLContext", None)
    if cls is None:
        return "none"
    name = getattr(cls, "__module__", "").rsplit(".", 1)[-1]
    return name or "unknown"


_PROBE_CODE = (
    "import mujoco\n"
    "ctx = mujoco.GLContext(16, 16)\n"
    "ctx.make_current()\n"
    "m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><camera name=\"c\"/>"
    "<geom size=\".1\"/></worldbody></mujoco>')\n"
    "ctx.free()\n"
    "r = mujoco.Renderer(m, 8, 8)\n"
    "d = mujoco.MjData(m); mujoco.mj_forward(m, d); r.update_scene(d, 'c'); r.render()\n"
    "r.close()\n"
)


def _probe_subprocess(backend: str, timeout_s: float = 120.0) -> str | None:
    """Try ``backend`` in a fresh interpreter; None when it renders, else the reason."""
    env = dict(os.environ, MUJOCO_GL=backend)
    if backend == "osmesa":
        env.setdefault("PYOPENGL_PLATFORM", "osmesa")
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE_CODE], env=env,
                              capture_output=True, text=True, timeout=timeout_s)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"{type(exc).__name__}: {exc}"
    if proc.returncode == 0:
        return None
    lines = [ln for ln in proc.stderr.strip().splitlines() if ln.strip()]
    return lines[-1].strip() if lines else f"exit code {proc.returncode}"


_INPROCESS_FAILURE: dict[str, str] = {}


def _probe_inprocess() -> str | None:
    """Try the backend this process's mujoco was (or will be) imported with. A renderer
    that already failed in this process marks it unusable (a second MuJoCo context after a
    failed one can abort the interpreter)."""
    if "reason" in _INPROCESS_FAILURE:
        return _INPROCESS_FAILURE["reason"]
    try:
        mujoco = _import_mujoco()
        if loaded_backend() == "glfw" and not (os.environ.get("DISPLAY")
                                               or os.environ.get("WAYLAND_DISPLAY")):
            return "glfw needs a display (DISPLAY is not set)"
        ctx = mujoco.GLContext(16, 16)
        ctx.make_current()
        ctx.free()
    except Exception as exc:  # noqa: BLE001  (any GL failure means: not usable)
        return f"{type(exc).__name__}: {exc}".strip()
    return None


_BACKEND_CACHE: dict[str, Any] = {}


def available_backend(probe_inprocess: Callable[[], str | None] | None = None,
                      probe_subprocess: Callable[[str], str | None] | None = None
                      ) -> tuple[str, bool]:
    """Find a working rendering backend: ``(MUJOCO_GL value, usable in this process)``.

    Tries the backend this process uses (``MUJOCO_GL``, default ``egl``) in-process first
    (cheap); if that fails, tries the other backends in fresh interpreters (``egl`` then
    ``osmesa``) — a working one is then used in worker processes. Raises
    :class:`RenderBackendError` naming the packages to install when none works. The
    probes are injectable for tests; the default result is cached per process.
    """
    use_cache = probe_inprocess is None and probe_subprocess is None
    if use_cache and "result" in _BACKEND_CACHE:
        return _BACKEND_CACHE["result"]
    probe_inprocess = probe_inprocess or _probe_inprocess
    probe_subprocess = probe_subprocess or _probe_subprocess
    _ensure_env_default()
    current = os.environ.get("MUJOCO_GL", "egl")
    failures: dict[str, str] = {}
    why = probe_inprocess()
    if why is not None and "mujoco" in sys.modules and probe_inprocess is _probe_inprocess:
        actual = loaded_backend()
        if actual != current:
            current = actual
            why += (f" (mujoco was imported with the {actual} backend before MUJOCO_GL was "
                    "set; set MUJOCO_GL=egl before importing mujoco)")
    if why is None:
        result = (current, True)
    else:
        failures[current] = why
        result = None
        for name in _BACKENDS:
            if name in failures:
                continue
            why = probe_subprocess(name)
            if why is None:
                result = (name, False)
                break
            failures[name] = why
        if result is None:
            raise RenderBackendError(backend_error_message(failures))
    if use_cache:
        _BACKEND_CACHE["result"] = result
    return result


# ----------------------------------------------------------------------------- model I/O
def model_to_bytes(model) -> bytes:
    """Serialise a compiled ``MjModel`` (MuJoCo binary format) for worker processes."""
    import pickle  # noqa: PLC0415
    return pickle.dumps(model, protocol=pickle.HIGHEST_PROTOCOL)


def model_from_bytes(blob: bytes):
    import pickle  # noqa: PLC0415
    _import_mujoco()
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
        mujoco = _import_mujoco()
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
            _INPROCESS_FAILURE.setdefault("reason", reason)
            _BACKEND_CACHE.pop("result", None)
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


# ------------------------------------------------------------------------- parallel map
@dataclass(frozen=True)
class FrameJob:
    """One frame to render: camera name, frame index, raw MuJoCo state, and ``key`` (any
    picklable data the per-frame function needs, e.g. a seed key).

    ``substates``: ``((qpos, mocap_pos, mocap_quat_wxyz), ...)`` — when given, each is
    rendered and the per-frame function receives the ``(S, H, W, 3)`` stack (motion blur,
    rolling shutter); the frame's own state still defines ``FrameTiming.T_world_cam``.
    ``light``: ``(intensity scale, azimuth offset rad)`` for :meth:`CameraRenderer.set_light`
    (``None``: the model's lights). ``check_points``: ``(N, 3)`` world points tested for
    occlusion at the frame's state (``FrameTiming.occluded``)."""
    camera: str
    frame_index: int
    qpos: np.ndarray | None
    mocap_pos: np.ndarray | None
    mocap_quat_wxyz: np.ndarray | None
    key: Any = None
    substates: tuple = ()
    light: tuple | None = None
    check_points: np.ndarray | None = None


@dataclass(frozen=True)
class FrameTiming:
    """Seconds spent on one frame: ``render_s`` (wall, rendering only), ``total_s`` (wall,
    rendering + the per-frame function), ``cpu_s`` (CPU time of the rendering process
    over both, all its threads — independent of other load on the machine), ``pid`` (the
    process that rendered it), ``T_world_cam`` (the OpenCV-frame pose of the camera in the
    rendered state — lets callers check the state against their ground truth)."""
    render_s: float
    total_s: float
    cpu_s: float
    pid: int
    T_world_cam: np.ndarray
    occluded: np.ndarray | None = None


_WORKER: dict[str, Any] = {}

#: Fewest frames per rendering process before another worker process is started.
MIN_JOBS_PER_WORKER = 12


def _worker_init(model_blob: bytes, settings: RenderSettings, backend: str,
                 fn: Callable) -> None:
    os.environ["MUJOCO_GL"] = backend
    if backend == "osmesa":
        os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
    # One thread per worker: the pool already uses every core.
    os.environ.setdefault("LP_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        import cv2  # noqa: PLC0415
        cv2.setNumThreads(1)
    except ImportError:
        pass
    _WORKER["fn"] = fn
    try:
        _WORKER["renderer"] = CameraRenderer(model_from_bytes(model_blob), settings)
    except Exception as exc:  # noqa: BLE001  (re-raised in the parent by the first task)
        _WORKER["error"] = exc


def _run_jobs(renderer: CameraRenderer, fn: Callable, jobs: Sequence[FrameJob]) -> list:
    out = []
    for job in jobs:
        c0 = time.process_time()
        t0 = time.perf_counter()
        renderer.set_light(*(job.light if job.light is not None else (1.0, 0.0)))
        if job.substates:
            img = np.stack([renderer.render(job.camera, *st) for st in job.substates])
            renderer.set_state(job.qpos, job.mocap_pos, job.mocap_quat_wxyz)
        else:
            img = renderer.render(job.camera, job.qpos, job.mocap_pos, job.mocap_quat_wxyz)
        T = renderer.T_world_cam(job.camera)
        occ = None if job.check_points is None else renderer.occluded(job.camera,
                                                                      job.check_points)
        t1 = time.perf_counter()
        res = img if fn is None else fn(img, job)
        out.append((res, FrameTiming(t1 - t0, time.perf_counter() - t0,
                                     time.process_time() - c0, os.getpid(), T, occ)))
    return out


def _worker_chunk(jobs: Sequence[FrameJob]) -> list:
    if "error" in _WORKER:
        raise _WORKER["error"]
    return _run_jobs(_WORKER["renderer"], _WORKER["fn"], jobs)


def default_workers() -> int:
    """Worker processes used by default: the usable cores (at least 1)."""
    from simcalib.parallel import default_workers as _dw  # noqa: PLC0415
    return _dw()


class RenderInterrupted(KeyboardInterrupt):
    """Ctrl-C (or another interrupt) during :func:`render_map`, carrying what was done.

    ``results`` / ``timings``: lists in job order, ``None`` for frames not rendered;
    ``n_done``: frames rendered. A ``KeyboardInterrupt``, so code that does not handle it
    still stops as on Ctrl-C.
    """

    def __init__(self, results: list, timings: list):
        super().__init__("rendering interrupted")
        self.results = results
        self.timings = timings
        self.n_done = sum(r is not None for r in timings)


class LineProgress:
    """Progress callback ``(n_done, n_total)`` that prints a line to ``stream`` (stderr)
    every ``every`` frames and at the end — for logs and non-terminal stderr, where a bar
    would print nothing useful."""

    def __init__(self, label: str = "frames", every: int = 100, stream=None):
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise ValueError(f"every must be a positive integer; received {every!r}")
        self.label, self.every, self.stream = label, every, stream
        self._last = 0
        self._t0 = time.perf_counter()

    def __call__(self, n_done: int, n_total: int) -> None:
        if n_done - self._last < self.every and n_done < n_total:
            return
        if n_done == self._last:
            return
        self._last = n_done
        dt = time.perf_counter() - self._t0
        rate = n_done / dt if dt > 0 else float("inf")
        print(f"{self.label}: {n_done}/{n_total} ({rate:.1f}/s)",
              file=self.stream or sys.stderr, flush=True)


def render_map(model, settings: RenderSettings, jobs: Sequence[FrameJob],
               fn: Callable[[np.ndarray, FrameJob], Any] | None = None,
               workers: int | None = None, chunk_size: int = 8,
               use_this_process: bool = True,
               progress: Callable[[int, int], None] | None = None
               ) -> tuple[list, list[FrameTiming]]:
    """Render every job's frame and return ``([fn(image, job) ...], [FrameTiming ...])``
    in job order.

    ``fn`` must be picklable (a module-level function or an instance of a module-level
    class) and deterministic given ``(image, job)``; ``None`` returns the images.
    ``workers``: ``None`` = all usable cores; ``1`` renders in this process (or in one
    worker process when only a fallback backend works); ``n > 1`` renders in this process
    plus ``n - 1`` spawned worker processes (``n`` spawned ones when this process cannot
    render, or with ``use_this_process=False``). The results do not depend on ``workers``,
    ``chunk_size`` or ``use_this_process``.

    ``progress(n_done, n_total)`` is called in this process as frames complete (per frame
    rendered here, per chunk from workers). An interrupt (Ctrl-C) stops the workers
    quietly and raises :class:`RenderInterrupted` carrying the frames already rendered.
    """
    if workers is None:
        workers = default_workers()
    _check_map_options(workers, chunk_size, progress)
    jobs = list(jobs)
    if not jobs:
        return [], []
    backend, inprocess = available_backend()
    inprocess = inprocess and bool(use_this_process)
    # Starting a worker costs ~1 s (a fresh interpreter importing mujoco and cv2): not
    # worth it below ~MIN_JOBS_PER_WORKER frames per process.
    workers = int(min(workers, -(-len(jobs) // MIN_JOBS_PER_WORKER)))
    if workers == 1 and inprocess:
        pairs = _pairs_rendered_here(model, settings, jobs, fn, progress)
    else:
        pairs = _pairs_rendered_in_pool(model, settings, jobs, fn, workers, chunk_size,
                                        backend, inprocess, progress)
    return [p[0] for p in pairs], [p[1] for p in pairs]


def check_progress(progress) -> None:
    """Raise TypeError unless ``progress`` is a callable ``(n_done, n_total)`` or None."""
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable (n_done, n_total) or None; received "
                        f"{type(progress).__name__}")


def _check_map_options(workers, chunk_size, progress) -> None:
    """Raise the error of the first invalid ``workers``/``chunk_size``/``progress``."""
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer or None; received {workers!r}")
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) \
            or chunk_size < 1:
        raise ValueError(f"chunk_size must be a positive integer; received {chunk_size!r}")
    check_progress(progress)


def _render_each(renderer: CameraRenderer, fn: Callable, jobs: Sequence[FrameJob], out: list,
                 done_before: int, n_total: int, progress, intr) -> None:
    """Append each job's (result, timing) pair to ``out``; progress and interrupt per frame."""
    for job in jobs:
        out += _run_jobs(renderer, fn, [job])
        if progress is not None:
            progress(done_before + len(out), n_total)
        intr.check()


def _pairs_rendered_here(model, settings: RenderSettings, jobs: list, fn: Callable,
                         progress) -> list:
    """(result, timing) pairs of ``jobs`` rendered one by one in this process."""
    from simcalib.parallel import deferred_interrupt  # noqa: PLC0415
    n_total = len(jobs)
    pairs: list = []
    try:
        with deferred_interrupt() as intr, CameraRenderer(model, settings) as r:
            _render_each(r, fn, jobs, pairs, 0, n_total, progress, intr)
    except KeyboardInterrupt:
        pad = [None] * (n_total - len(pairs))
        raise RenderInterrupted([p[0] for p in pairs] + pad,
                                [p[1] for p in pairs] + pad) from None
    return pairs


def _job_chunks(jobs: list, workers: int, chunk_size: int) -> list:
    """Contiguous chunks of ``jobs``, several per worker for load balance."""
    size = int(max(1, min(chunk_size, -(-len(jobs) // (2 * workers)))))
    return [jobs[i:i + size] for i in range(0, len(jobs), size)]


class _ChunkPairs:
    """Each chunk's (result, timing) pairs as they arrive (``None``: not yet); frames done."""

    def __init__(self, n_chunks: int, n_total: int, progress):
        self.pairs: list = [None] * n_chunks
        self.done = 0
        self.n_total = n_total
        self.progress = progress

    def store(self, i: int, part: list) -> None:
        """Record chunk ``i``'s pairs and count its frames as done."""
        self.pairs[i] = part
        self.done += len(part)

    def collect(self, futures, block: bool) -> None:
        """Store finished worker chunks (``block``: wait up to 0.2 s first); report progress."""
        from concurrent.futures import FIRST_COMPLETED, wait  # noqa: PLC0415
        pending = [f for i, f in enumerate(futures) if self.pairs[i] is None]
        if block and pending:
            wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
        for i, f in enumerate(futures):
            if self.pairs[i] is None and f.done() and not f.cancelled():
                self.store(i, f.result())
        if self.progress is not None:
            self.progress(self.done, self.n_total)

    def interrupted(self, chunks: list) -> RenderInterrupted:
        """The :class:`RenderInterrupted` of the chunks done (``None`` per frame of the others)."""
        res_out: list = []
        tim_out: list = []
        for c, chunk_res in zip(chunks, self.pairs):
            if chunk_res is None:
                res_out += [None] * len(c)
                tim_out += [None] * len(c)
            else:
                res_out += [p[0] for p in chunk_res]
                tim_out += [p[1] for p in chunk_res]
        return RenderInterrupted(res_out, tim_out)


def _submitted_chunks(pool, chunks: list, intr) -> list:
    """Futures of every chunk submitted to ``pool``; interrupt checked after each."""
    futures = []
    for c in chunks:
        futures.append(pool.submit(_worker_chunk, c))
        intr.check()
    return futures


def _render_unstarted_chunks_here(model, settings: RenderSettings, fn: Callable, chunks: list,
                                  futures: list, book: _ChunkPairs, intr) -> None:
    """Render here, last chunk first, every chunk whose future could still be cancelled."""
    with CameraRenderer(model, settings) as r:
        for i in range(len(chunks) - 1, -1, -1):
            if futures[i].cancel():
                part: list = []
                _render_each(r, fn, chunks[i], part, book.done, book.n_total, book.progress,
                             intr)
                book.store(i, part)
                book.collect(futures, block=False)


def _pairs_rendered_in_pool(model, settings: RenderSettings, jobs: list, fn: Callable,
                            workers: int, chunk_size: int, backend: str, inprocess: bool,
                            progress) -> list:
    """(result, timing) pairs of ``jobs`` rendered in chunks by worker processes (and here)."""
    from simcalib.parallel import deferred_interrupt, worker_pool  # noqa: PLC0415
    blob = model_to_bytes(model)
    chunks = _job_chunks(jobs, workers, chunk_size)
    # When this process can render, it is one of the workers: it starts at once (no
    # interpreter start-up) and takes chunks from the end while the spawned processes
    # take them from the front. Chunk results do not depend on who renders them.
    n_proc = workers - 1 if inprocess else workers
    book = _ChunkPairs(len(chunks), len(jobs), progress)
    try:
        # Do not wait for workers that are still starting up once every result is in:
        # they receive the shutdown request and exit on their own.
        with deferred_interrupt() as intr, \
                worker_pool(n_proc, _worker_init, (blob, settings, backend, fn),
                            wait=False) as pool:
            futures = _submitted_chunks(pool, chunks, intr)
            if inprocess:
                _render_unstarted_chunks_here(model, settings, fn, chunks, futures, book, intr)
            while any(r is None for r in book.pairs):
                book.collect(futures, block=True)
                intr.check()
    except KeyboardInterrupt:
        raise book.interrupted(chunks) from None
    return [p for chunk in book.pairs for p in chunk]
