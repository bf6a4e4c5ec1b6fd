"""The OpenGL backend of MuJoCo's offscreen rendering: chosen once, probed, explained.

MuJoCo reads ``MUJOCO_GL`` once, at import. No simcalib module sets it at import time;
:func:`import_mujoco` (the one way simcalib imports mujoco) lets :func:`select_backend`
decide once, when MuJoCo is first needed: unset -> ``egl``, ``osmesa`` without libOSMesa ->
``egl`` with a warning naming the package, an unknown value -> :class:`RenderBackendError`
listing the valid ones. If the chosen backend cannot create an OpenGL context
(:func:`available_backend`), ``egl`` then ``osmesa`` are probed in fresh interpreters and a
working one is used in worker processes; if none works, :class:`RenderBackendError` names
the Debian packages to install. The renderer is :mod:`simcalib.world.render`.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from typing import Any, Callable

#: No usable OpenGL backend for MuJoCo offscreen rendering (CLI exit code 4): the
#: project-wide :class:`simcalib.errors.BackendError` under the name rendering code uses.
from simcalib.errors import BackendError as RenderBackendError

__all__ = ["DEBIAN_PACKAGES", "RenderBackendError", "VALID_BACKENDS", "available_backend",
           "backend_error_message", "import_mujoco", "loaded_backend", "mark_unusable",
           "select_backend"]

#: Debian/Ubuntu packages each backend needs (docs/platform.md).
DEBIAN_PACKAGES = {
    "egl": "libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri",
    "osmesa": "libosmesa6",
}
_BACKENDS = ("egl", "osmesa")


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


def loaded_backend() -> str:
    """The OpenGL backend the imported mujoco actually uses (``egl``, ``osmesa``, ``glfw``,
    or ``none``); mujoco picks it once, at import, from ``MUJOCO_GL``."""
    mujoco = import_mujoco()
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
        mujoco = import_mujoco()
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
    select_backend()
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


def mark_unusable(reason: str) -> None:
    """Record that rendering failed in this process (``reason``): the in-process backend is
    then reported unusable (a second MuJoCo context after a failed one can abort the
    interpreter) and :func:`available_backend` probes again."""
    _INPROCESS_FAILURE.setdefault("reason", reason)
    _BACKEND_CACHE.pop("result", None)
