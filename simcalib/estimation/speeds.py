"""The motion speeds of a pose stream: the signals the clock offset correlates.

``angular_speed`` (a rig that turns) and ``translation_speed`` (one that only translates)
need no reading of the stream (the same for T_world_sensor and its inverse; for the
translation speed, without rotation). :func:`speed_steps` takes both streams' speeds over
about the slower stream's period; :func:`as_time_poses` checks a stream where it enters the
time alignment.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["as_time_poses", "apart", "above_noise", "NOISE_GAIN", "angular_speed",
           "translation_speed", "speed_steps", "SPEEDS", "checked_signal"]

#: a motion rises above a stream's pose noise when it moves this many times the stream's
#: median motion from one pose to the next (:func:`above_noise`)
NOISE_GAIN = 3.0


def as_time_poses(stream, name: str = "stream") -> tuple[np.ndarray, np.ndarray]:
    """``(t (N,), T (N,4,4))`` from a PoseStreamData, a PoseStream or a ``(t, T)`` tuple."""
    if isinstance(stream, tuple) and len(stream) == 2:
        t, T = stream
    elif hasattr(stream, "T_world_sensor"):
        t, T = stream.timestamps_s, stream.T_world_sensor
    elif hasattr(stream, "T_world_cam"):
        t, T = stream.timestamp_s, stream.T_world_cam
    else:
        raise TypeError(f"{name} must be a PoseStreamData, a PoseStream or a (timestamps_s, "
                        f"T_world_sensor) tuple; received {type(stream).__name__}")
    t = np.asarray(t, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    if T.ndim != 3 or T.shape[1:] != (4, 4) or t.shape != (T.shape[0],):
        raise ValueError(f"{name}: need timestamps (N,) and poses (N, 4, 4); received "
                         f"{t.shape} and {T.shape}")
    if t.size < 3:
        raise ValueError(f"{name}: at least 3 poses are needed; received {t.size}")
    if not (np.isfinite(t).all() and np.isfinite(T).all()):
        raise ValueError(f"{name}: timestamps and poses must be finite")
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"{name}: timestamps must be strictly increasing (read files with "
                         "simcalib.importers, which repairs order and duplicates)")
    return t, T


def _step(step, n: int) -> int:
    """The sample step of a speed: ``step`` (an integer >= 1) capped at ``n - 1``."""
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise ValueError(f"step must be an integer >= 1; received {step!r}")
    return int(min(step, max(1, n - 1)))


def apart(T: np.ndarray, k: int, signal: str = "rotation") -> np.ndarray:
    """The rotation angle (rad; ``signal`` ``rotation``) or the distance (``translation``)
    between poses ``T`` (n, 4, 4) ``k`` samples apart, ``(n - k,)``."""
    if signal == "translation":
        return np.linalg.norm(T[k:, :3, 3] - T[:-k, :3, 3], axis=1)
    return rotation_angle_rad(np.swapaxes(T[:-k, :3, :3], 1, 2) @ T[k:, :3, :3])


def above_noise(moved, T: np.ndarray, signal: str = "rotation",
                gain: float = NOISE_GAIN) -> np.ndarray:
    """Which of the motions ``moved`` (rotation angles, rad, or distances: ``signal``) of
    the stream of poses ``T`` (n, 4, 4) rise above its pose-to-pose noise: more than
    ``gain`` times the median angle (distance) between consecutive poses of ``T``. That
    median is the noise where the stream stands still (or moves less per sample than its
    noise), and at most the motion over one sample where it moves: a motion of many
    samples is ~``k`` times it, while noise alone stays ~1x whatever the span. The one
    rule for "the motion is more than noise" of the clock offset's cost
    (:class:`~simcalib.estimation.offset_cost.OffsetCost`) and of the base stride of
    sample-number stamps (:func:`~simcalib.estimation.hidden_offset.motion_stride`)."""
    return np.asarray(moved, dtype=np.float64) > gain * float(np.median(apart(T, 1, signal)))


def angular_speed(stream, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``(t_mid, speed_rad_s)``: rotation angle between poses ``step`` samples apart over
    their time difference, at the midpoints. The same for a stream and its inverse
    (T_world_sensor or T_sensor_world), so it needs no convention. A fast stream's pose
    noise over one short step can swamp the motion (0.1 deg at 300 Hz reads as 40 deg/s);
    over ``step`` samples it is ``step`` times smaller (:func:`speed_steps`)."""
    return _speed(stream, step, "rotation")


def translation_speed(stream, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``(t_mid, speed_m_s)``: distance between positions ``step`` samples apart over their
    time difference, at the midpoints. Without rotation it is the same in every sensor of a
    rigid rig (``|t_C| = |t_H|``) and for a stream and its inverse, so it needs no
    convention there; the clock offset of a rig that only translates is read from it."""
    return _speed(stream, step, "translation")


def _speed(stream, step, signal: str) -> tuple[np.ndarray, np.ndarray]:
    t, T = as_time_poses(stream)
    k = _step(step, t.size)
    return 0.5 * (t[:-k] + t[k:]), apart(T, k, signal) / (t[k:] - t[:-k])


def speed_steps(t_a: np.ndarray, t_b: np.ndarray) -> tuple[int, int]:
    """The sample steps over which the two streams' speeds are taken for the correlation:
    both over about the slower stream's period (the faster one's speeds are smoothed to
    that period on the grid anyway, but the noise of a speed's short baseline does not
    average out: its magnitude is biased, so it stays as a noise floor)."""
    dt_a, dt_b = float(np.median(np.diff(t_a))), float(np.median(np.diff(t_b)))
    slow = max(dt_a, dt_b)
    return (max(1, int(round(slow / dt_a))) if dt_a > 0 else 1,
            max(1, int(round(slow / dt_b))) if dt_b > 0 else 1)


#: the speed each motion signal correlates (:mod:`simcalib.estimation.stillness`)
SPEEDS = {"rotation": angular_speed, "translation": translation_speed}


def checked_signal(signal, stream_a, stream_b) -> str:
    """The checked motion signal; ``auto``: rotation unless neither stream turns."""
    if signal == "auto":
        from simcalib.estimation.stillness import motion_signal
        return motion_signal(stream_a, stream_b)
    if signal not in SPEEDS:
        raise ValueError(f"signal must be 'auto', 'rotation' or 'translation'; received "
                         f"{signal!r}")
    return signal
