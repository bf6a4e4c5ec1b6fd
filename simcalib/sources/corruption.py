"""Corruption applied after a source measured: injected outliers with ground-truth labels,
and the record of each stream's clock.

Outliers (``outliers.*``, :class:`OutliersConfig`): a fraction of each selected stream's
delivered poses is replaced, after the source measured them, by one of

* ``random_pose``: a uniformly random rotation and a position uniform in the stream's
  bounding box grown by ``random_margin_m`` on every side;
* ``flipped_marker``: the planar-target PnP ambiguity (an IPPE flip): the marker nearest
  the pose's optical axis (in front of it) is kept at the same place in the camera image
  but its tilt is mirrored about the line of sight — the marker's normal ``n`` reflected
  about the viewing ray ``r`` (a rotation of the marker about its centre by twice the
  angle between ``n`` and ``r``, about ``n x r``); the pose reported is the camera pose
  that sees that mirrored marker;
* ``swapped_frames``: poses exchanged among the chosen frames (a cyclic shift in random
  order, so every one of them carries another frame's pose; timestamps stay).

``kind=mixed`` draws each outlier's kind uniformly from the three (from the other two when
there is no marker map). The labels (frame index,
timestamp, kind and how far each corrupted pose is from the clean one) go to results.json
``outliers`` so a robust estimator can be scored; ``PoseStream.info["outlier"]`` marks them.
Draws come from the run's ``outliers`` generator, split per camera.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from simcalib.config.checks import check_in, check_names, check_range, set_fields
from simcalib.config.engine import key_help

__all__ = ["OUTLIER_KINDS", "OutliersConfig", "inject_outliers", "outlier_pairs",
           "clock_report"]

OUTLIER_KINDS = ("random_pose", "flipped_marker", "swapped_frames")



@dataclass(frozen=True)
class OutliersConfig:
    """Injected outliers (``outliers.*``); off by default (``fraction=0``)."""
    fraction: float = field(default=0.0, metadata=key_help(
        "fraction of each selected stream's delivered poses replaced by outliers, [0, 0.5]"))
    kind: str = field(default="mixed", metadata=key_help(
        "random_pose | flipped_marker | swapped_frames | mixed (each outlier's kind drawn "
        "uniformly)"))
    apply_to: tuple[str, ...] = field(default=("a", "b"), metadata=key_help(
        "streams that get outliers: a (cam_a), b (cam_b)"))
    random_margin_m: float = field(default=0.5, metadata=key_help(
        "random_pose: positions uniform in the stream's bounding box grown by this, metres"))

    def __post_init__(self):
        set_fields(
            self,
            fraction=check_range("fraction", self.fraction, lo=0.0, hi=0.5),
            kind=check_in("kind", self.kind, OUTLIER_KINDS + ("mixed",)),
            apply_to=check_names("apply_to", self.apply_to, ("a", "b")),
            random_margin_m=check_range("random_margin_m", self.random_margin_m, lo=0.0))

    @property
    def active(self) -> bool:
        return self.fraction > 0


# ----------------------------------------------------------------------------- kinds
def _random_rotations(n: int, rng) -> np.ndarray:
    from simcalib.geometry import matrix_from_quat
    q = rng.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return matrix_from_quat(q)


def _random_poses(T_all: np.ndarray, n: int, margin: float, rng) -> np.ndarray:
    p = T_all[:, :3, 3]
    lo, hi = p.min(axis=0) - margin, p.max(axis=0) + margin
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = _random_rotations(n, rng)
    out[:, :3, 3] = lo + (hi - lo) * rng.random((n, 3))
    return out


def _rotation_about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    from simcalib.geometry import matrix_from_rotvec
    return matrix_from_rotvec(axis * angle[:, None])


def flipped_marker_poses(T_world_cam: np.ndarray, marker_field) -> np.ndarray:
    """``(K, 4, 4)``: each pose's IPPE-flip counterpart about the marker nearest its
    optical axis (module docstring). A pose with no marker in front keeps its value."""
    from simcalib.geometry import invert_transform
    T = np.asarray(T_world_cam, dtype=np.float64)
    Tm = np.asarray(marker_field.T_world_marker, dtype=np.float64)       # (M, 4, 4)
    T_cw = invert_transform(T)
    p_c = np.einsum("kij,mj->kmi", T_cw[:, :3, :3], Tm[:, :3, 3]) + T_cw[:, None, :3, 3]
    depth = p_c[..., 2]
    ang = np.arccos(np.clip(depth / np.maximum(np.linalg.norm(p_c, axis=-1), 1e-12), -1, 1))
    ang = np.where(depth > 0.05, ang, np.inf)
    j = np.argmin(ang, axis=1)
    ok = np.isfinite(ang[np.arange(len(j)), j])
    T_cm = T_cw @ Tm[j]                                                  # marker in camera
    n = T_cm[:, :3, 2]                                                   # marker normal
    r = -T_cm[:, :3, 3] / np.linalg.norm(T_cm[:, :3, 3], axis=1, keepdims=True)  # to camera
    axis = np.cross(n, r)
    s = np.linalg.norm(axis, axis=1)
    phi = np.arctan2(s, np.einsum("ki,ki->k", n, r))
    axis = np.where(s[:, None] > 1e-12, axis / np.maximum(s, 1e-12)[:, None],
                    np.array([1.0, 0.0, 0.0]))
    Q = _rotation_about(axis, 2.0 * phi)
    T_cm_f = T_cm.copy()
    T_cm_f[:, :3, :3] = Q @ T_cm[:, :3, :3]
    out = Tm[j] @ invert_transform(T_cm_f)
    return np.where(ok[:, None, None], out, T)


# ----------------------------------------------------------------------------- apply
def _inject_one(stream, cfg: OutliersConfig, rng, marker_field):
    from simcalib.geometry import rotation_error_rad, translation_error_m
    n = stream.n_used
    k = int(round(cfg.fraction * n))
    T = np.array(stream.T_world_cam, dtype=np.float64)
    clean = T.copy()
    if k == 0:
        return stream, np.zeros(0, int), []
    pos = np.sort(rng.choice(n, size=k, replace=False))
    if cfg.kind == "mixed":   # flipped_marker only where there is a marker map
        avail = OUTLIER_KINDS if marker_field is not None else ("random_pose",
                                                                 "swapped_frames")
        kinds = np.array(avail)[rng.integers(0, len(avail), size=k)]
    else:
        kinds = np.full(k, cfg.kind)
    sw = pos[kinds == "swapped_frames"]
    if sw.size == 1:                     # a swap needs a partner: the nearest free frame
        free = np.setdiff1d(np.arange(n), pos)
        if free.size == 0:
            kinds[kinds == "swapped_frames"] = "random_pose"
        else:
            partner = free[rng.integers(0, free.size)]
            pos = np.append(pos, partner)
            kinds = np.append(kinds, "swapped_frames")
            order = np.argsort(pos)
            pos, kinds = pos[order], kinds[order]
            sw = pos[kinds == "swapped_frames"]
    if sw.size >= 2:
        perm = rng.permutation(sw)
        T[perm] = clean[np.roll(perm, -1)]
    rp = pos[kinds == "random_pose"]
    if rp.size:
        T[rp] = _random_poses(clean, rp.size, cfg.random_margin_m, rng)
    fm = pos[kinds == "flipped_marker"]
    if fm.size:
        if marker_field is None:
            raise ValueError("outliers.kind=flipped_marker needs a marker field (a simulated "
                             "world); use random_pose or swapped_frames")
        T[fm] = flipped_marker_poses(clean[fm], marker_field)
    mask = np.zeros(n, dtype=bool)
    mask[pos] = True
    kind_arr = np.full(n, "", dtype=object)
    kind_arr[pos] = kinds
    info = dict(stream.info) | {"outlier": mask, "outlier_kind": kind_arr}
    out = dataclasses.replace(stream, T_world_cam=T, info=info)
    labels = [{"frame_index": int(stream.frame_index[p]),
               "timestamp_s": float(stream.timestamp_s[p]), "kind": str(kd),
               "rotation_deg": float(np.rad2deg(rotation_error_rad(T[p], clean[p]))),
               "translation_m": float(translation_error_m(T[p], clean[p]))}
              for p, kd in zip(pos, kinds)]
    return out, pos, labels


def inject_outliers(streams: dict, cfg: OutliersConfig, rng: np.random.Generator,
                    marker_field=None) -> tuple[dict, dict]:
    """``(streams with outliers, labels)``. ``streams``: camera -> PoseStream (as measured);
    ``labels``: results.json ``outliers`` (config, then per camera ``n_poses``,
    ``n_outliers``, ``by_kind`` and ``labels`` — one dict per outlier: ``frame_index``,
    ``timestamp_s``, ``kind``, ``rotation_deg`` / ``translation_m`` from the clean pose).
    The generator is split per camera (``cam_a``, ``cam_b``) whatever is selected."""
    from simcalib.config.engine import to_dict
    from simcalib.sources.base import CAMERAS
    from simcalib.sources.selection import STREAM_CAMERAS
    rngs = dict(zip(CAMERAS, rng.spawn(len(CAMERAS))))
    out = dict(streams)
    report = {"enabled": cfg.active, "config": to_dict(cfg)}
    if not cfg.active:
        return out, report
    for key in cfg.apply_to:
        cam = STREAM_CAMERAS[key]
        if cam not in streams:
            continue
        out[cam], pos, labels = _inject_one(streams[cam], cfg, rngs[cam], marker_field)
        by_kind = {kd: sum(1 for lb in labels if lb["kind"] == kd) for kd in OUTLIER_KINDS}
        report[cam] = {"n_poses": int(streams[cam].n_used), "n_outliers": len(labels),
                       "by_kind": by_kind, "labels": labels}
    return out, report


def outlier_pairs(pairs, report: dict) -> dict:
    """Which motion pairs contain an injected outlier (results.json ``outliers.pairs``):
    ``n_pairs``, ``n_contaminated``, ``pair_index`` (indices into the solver's pairs)."""
    bad = np.zeros(pairs.n, dtype=bool)
    for cam, frames, in (("cam_a", pairs.frame_a), ("cam_b", pairs.frame_b)):
        lab = report.get(cam)
        if not lab:
            continue
        f = np.array([d["frame_index"] for d in lab["labels"]], dtype=np.int64)
        hit = np.isin(np.asarray(frames), f)
        bad |= hit[np.asarray(pairs.start)] | hit[np.asarray(pairs.end)]
    return {"n_pairs": int(pairs.n), "n_contaminated": int(bad.sum()),
            "pair_index": np.flatnonzero(bad).tolist()}


# ------------------------------------------------------------------------------ clocks
def clock_report(world) -> dict:
    """results.json ``clocks``: per camera, the clock as set (``world.cam_*``: fps, capture
    offset/jitter, clock offset, drift, stamp jitter) and as recovered from the ground
    truth — a least-squares line ``stamp = (1 + drift) * t_true + offset`` over every frame
    (``recovered_offset_s``, ``recovered_drift_ppm``, ``recovered_jitter_s`` the residual
    std) and the mean frame period of the true capture times."""
    out = {}
    for cam in world.camera_names:
        fr = world.frames(cam)
        c = getattr(world.config, cam)
        t = np.asarray(fr.time_s, dtype=np.float64)
        s = np.asarray(getattr(fr, "stamp_s", t), dtype=np.float64)
        A = np.column_stack([t, np.ones_like(t)])
        (slope, icpt), *_ = np.linalg.lstsq(A, s, rcond=None)
        res = s - A @ np.array([slope, icpt])
        fps = getattr(c, "fps", None) or world.config.fps
        out[cam] = {"fps": float(fps), "n_frames": int(t.size),
                    "capture_offset_s": float(c.capture_offset_s),
                    "capture_jitter_s": float(c.capture_jitter_s),
                    "clock_offset_s": float(c.clock_offset_s),
                    "clock_drift_ppm": float(getattr(c, "clock_drift_ppm", 0.0)),
                    "stamp_jitter_s": float(c.stamp_jitter_s),
                    "recovered_offset_s": float(icpt),
                    "recovered_drift_ppm": float((slope - 1.0) * 1e6),
                    "recovered_jitter_s": float(res.std()),
                    "mean_period_s": float(np.diff(t).mean()) if t.size > 1 else None}
    return out
