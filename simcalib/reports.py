"""Run outputs: results.json, TUM trajectories, extrinsics JSON, console table, progress.

The results.json schema is documented in ``docs/results-schema.md``. Everything written
here is deterministic for a given config and seed except the fields named in
:data:`TIMING_FIELDS` (wall-clock durations).
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import math
import sys
from pathlib import Path
from typing import Iterable

import numpy as np

from simcalib.geometry import quat_from_matrix, rotvec_from_matrix

__all__ = ["SCHEMA_VERSION", "TIMING_FIELDS", "results_dict", "write_json", "write_tum",
           "extrinsics_dict", "summary_table", "progress", "progress_line", "strip_timing",
           "stage_frames", "frame_progress"]

SCHEMA_VERSION = 1
#: keys (anywhere in results.json) that hold wall-clock durations; everything else is
#: a deterministic function of the resolved config and seed.
TIMING_FIELDS = ("runtime_s", "timing_s")


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: Path, data: dict) -> Path:
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(_jsonable(data), indent=2, allow_nan=False) + "\n")
    tmp.replace(path)
    return path


def strip_timing(data):
    """Copy of a results dict without the wall-clock fields (for determinism checks)."""
    if isinstance(data, dict):
        return {k: strip_timing(v) for k, v in data.items() if k not in TIMING_FIELDS}
    if isinstance(data, list):
        return [strip_timing(v) for v in data]
    return data


def pose_dict(T: np.ndarray) -> dict:
    T = np.asarray(T, dtype=np.float64)
    return {"T": T.tolist(), "translation_m": T[:3, 3].tolist(),
            "quaternion_xyzw": quat_from_matrix(T[:3, :3]).tolist(),
            "rotvec_deg": np.rad2deg(rotvec_from_matrix(T[:3, :3])).tolist()}


#: what the console shows for a number that is not a measurement (with a footnote)
NOT_MEASURED = "—"
#: the reasons, in the words of the console footnotes and of results.json
REASON_ALL_PROJECTED = ("every translation direction is undetermined or poorly determined "
                        "and was projected out: no translation error is left to measure")
REASON_SIGMA_INFINITE = ("a direction of X is undetermined: its 1-sigma is infinite "
                         "(no finite uncertainty to report)")


def determined_translation(s) -> tuple[float | None, str | None]:
    """``(translation_error_determined_m, None)``, or ``(None, reason)`` when every
    translation direction was projected out (what is left is rounding, ~1e-15 m: not a
    measurement)."""
    axes = s.undetermined_translation_axes
    if s.translation_error_determined_m is None or axes is None:
        return s.translation_error_determined_m, None
    axes = np.atleast_2d(np.asarray(axes, dtype=np.float64))
    if axes.size and np.linalg.matrix_rank(axes, tol=1e-6) >= 3:
        return None, REASON_ALL_PROJECTED
    return s.translation_error_determined_m, None


def _sigma_reason(sigma) -> str | None:
    if sigma is not None and not math.isfinite(sigma):
        return REASON_SIGMA_INFINITE
    return None


def direction_state_of(s, d: dict) -> str:
    """The state of flagged direction ``d`` (an entry of ``s.undetermined_directions``) of
    solver result ``s``, by the one rule of
    :func:`simcalib.solvers.diagnostics.uncertainty.direction_state` (the words of
    ``Direction.summary``): with a prior, a direction the motions leave undetermined is
    bounded by the prior when the covariance is finite on the axes it touches."""
    from simcalib.solvers.diagnostics.uncertainty import direction_state as state
    if d.get("state"):
        return str(d["state"])
    with_prior = s.prior is not None
    return state(d["reason"], bool(d.get("determined_by_prior")), with_prior,
                 with_prior and _finite_along(s.covariance, d))


def _finite_along(cov, d: dict) -> bool:
    """True when ``cov`` (6x6, inf on undetermined axes) is finite on every axis that
    direction ``d`` has a part along (rotation axis, translation direction; > 5 %)."""
    if cov is None:
        return False
    part = np.concatenate([np.abs(d.get("rotation_axis_a", np.zeros(3))),
                           np.abs(d.get("translation_dir_a", np.zeros(3)))])
    var = np.diag(np.asarray(cov, dtype=np.float64))
    return bool(np.isfinite(var[part > 0.05]).all())


def solver_entry(s) -> dict:
    """results.json entry of one :class:`simcalib.pipeline.SolverResult`."""
    return {
        "method": s.method,
        "prior": s.prior,
        "alpha": s.alpha,
        "X": None if s.X is None else np.asarray(s.X).tolist(),
        "rotation_error_deg": s.rotation_error_deg,
        "translation_error_m": s.translation_error_m,
        "translation_error_determined_m": determined_translation(s)[0],
        # why translation_error_determined_m is null (not a measurement), else null
        "translation_error_determined_reason": determined_translation(s)[1],
        "cost": s.cost,
        "runtime_s": s.runtime_s,
        "success": s.success,
        "degenerate": s.degenerate,
        "undetermined": list(s.undetermined),
        "undetermined_directions": [dict(d) | {"state": direction_state_of(s, d)}
                                    for d in s.undetermined_directions],
        "undetermined_translation_axes": None if s.undetermined_translation_axes is None
        else np.asarray(s.undetermined_translation_axes).tolist(),
        "singular_values": None if s.singular_values is None
        else np.asarray(s.singular_values).tolist(),
        "message": s.message,
        "error": s.error,
        "sweep": [dict(e) for e in s.sweep],
        # docs/results-schema.md: covariance entries that are infinite
        # (undetermined directions) are written as null, like every non-finite number
        "covariance": None if s.covariance is None else np.asarray(s.covariance).tolist(),
        "std": None if s.std_deg is None else {"rotation_deg": list(s.std_deg),
                                               "translation_m": list(s.std_m)},
        "sigma_rotation_deg": s.sigma_rotation_deg,
        "sigma_translation_m": s.sigma_translation_m,
        # why sigma_rotation_deg / sigma_translation_m is null (not a number), else null
        "sigma_rotation_reason": _sigma_reason(s.sigma_rotation_deg),
        "sigma_translation_reason": _sigma_reason(s.sigma_translation_m),
        "verdict": {"verdict": s.verdict, "directions": list(s.verdict_directions)},
        "alpha_choice": s.alpha_choice,
        "oracle_alpha": s.oracle,
        "convergence": [dict(e) for e in s.convergence],
        # the part of "covariance" that the cameras' calibration uncertainty contributes
        # (results.json calibration_bias); null when none is included
        "covariance_calibration": _calibration_entry(getattr(s, "covariance_calibration",
                                                             None)),
        # how the covariance was computed: "sandwich" (first order) or "pose_simulation"
        # (motions sharing poses with white pose noise: simulated, with the bias)
        "uncertainty_model": getattr(s, "uncertainty_model", None),
    }


def _calibration_entry(cov):
    if cov is None:
        return None
    cov = np.asarray(cov, dtype=np.float64)
    s = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return {"covariance": cov.tolist(), "std": {"rotation_deg": np.degrees(s[:3]).tolist(),
                                                "translation_m": s[3:].tolist()}}


def results_dict(result) -> dict:
    """The results.json content of a :class:`simcalib.pipeline.RunResult`."""
    from simcalib import __version__
    from simcalib.config import to_dict
    cfg = result.config
    return {
        "schema_version": SCHEMA_VERSION,
        "simcalib_version": __version__,
        "scenario": cfg.scenario,
        "description": cfg.description,
        "kind": cfg.kind,
        "source": cfg.source,
        "seed": cfg.seed,
        "status": result.status,
        "error": result.error,
        "completed_stages": list(result.completed_stages),
        "config": to_dict(cfg),
        "X_true": None if result.X_true is None else np.asarray(result.X_true).tolist(),
        "frames": result.frames,
        "pairing": result.pairing,
        "pose_error": {cam: e.summary() | {"source": e.source}
                       for cam, e in result.pose_errors.items()},
        "solvers": {s.label: solver_entry(s) for s in result.solvers},
        "timing_s": dict(result.timing_s),
        "solver_kernels": getattr(result, "solver_kernels", "compiled"),
        **{key: _plain(getattr(result, "sensing", {}).get(key))
           for key in ("stream_sources", "robot", "clocks", "outliers", "calibration_bias",
                       "estimation", "eye_to_hand")},
    }


def _plain(obj):
    """JSON-ready copy (numpy arrays and scalars to lists / floats)."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def extrinsics_dict(result) -> dict:
    out = {"convention": "X = T_a_b: pose of camera b in camera a (p_a = X p_b); "
                         "quaternions (x, y, z, w)",
           "cameras": list(result.camera_names),
           "X_true": None if result.X_true is None else pose_dict(result.X_true),
           "estimates": {}}
    for s in result.solvers:
        if s.X is not None:
            out["estimates"][s.label] = pose_dict(s.X) | {
                "method": s.method, "alpha": s.alpha, "prior": s.prior is not None,
                "degenerate": s.degenerate, "undetermined": list(s.undetermined)}
    return out


def write_tum(path: Path, timestamp_s: np.ndarray, T_world_cam: np.ndarray) -> Path:
    """TUM trajectory file: the signature line ``# simcalib TUM trajectory`` (what the
    ``simcalib_tum`` importer recognises), the column header, then one line ``timestamp tx
    ty tz qx qy qz qw`` per pose."""
    from simcalib.importers.simcalib_tum import COLUMNS, SIGNATURE
    t = np.asarray(timestamp_s, dtype=np.float64)
    T = np.asarray(T_world_cam, dtype=np.float64)
    if T.shape[0] != t.shape[0]:
        raise ValueError(f"{t.shape[0]} timestamps for {T.shape[0]} poses")
    q = quat_from_matrix(T[:, :3, :3])
    rows = np.column_stack([t, T[:, :3, 3], q])
    path = Path(path)
    with path.open("w") as f:
        f.write(f"{SIGNATURE}\n{COLUMNS}\n")
        np.savetxt(f, rows, fmt="%.9f")
    return path


def _fmt(v, scale=1.0, digits=3):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    v = v * scale
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 10 ** -digits):
        return f"{v:.2e}"
    return f"{v:.{digits}f}"


def _pm(err, sigma, scale, digits):
    """``error ± predicted sigma`` (sigma :data:`NOT_MEASURED` when infinite: footnoted)."""
    e = _fmt(err, scale, digits)
    if sigma is None:
        return e
    sg = NOT_MEASURED if not math.isfinite(sigma) else _fmt(sigma, scale, digits)
    return f"{e} ± {sg}"


def _direction_tag(d: dict) -> str:
    word = d["kind"] if d["kind"] != "coupled" else "rot+trans"
    ax = d["translation_dir_a"] if d["kind"] == "translation" else d["rotation_axis_a"]
    i = int(np.argmax(np.abs(ax)))
    return f"{word} {'xyz'[i]}" if abs(ax[i]) > 0.9 else word


def _verdict_cell(s) -> str:
    """The flagged directions grouped by their state (worst first), each state in the words
    of ``Direction.summary`` (:func:`direction_state_of`)."""
    from simcalib.solvers.diagnostics.uncertainty import DIRECTION_STATES
    if s.verdict in ("determined", "unknown", "FAILED") or not s.undetermined_directions:
        return s.verdict
    by_state: dict[str, list[str]] = {}
    for d in s.undetermined_directions:
        tags = by_state.setdefault(direction_state_of(s, d), [])
        if _direction_tag(d) not in tags:
            tags.append(_direction_tag(d))
    order = sorted(by_state, key=lambda st: -DIRECTION_STATES.index(st)
                   if st in DIRECTION_STATES else 1)
    parts, shown = [], 0
    for st in order:
        tags = by_state[st][:max(0, 3 - shown)]
        shown += len(tags)
        if tags:
            parts.append(f"{st}: {', '.join(tags)}")
    hidden = sum(len(t) for t in by_state.values()) - shown
    return "; ".join(parts) + (f", +{hidden}" if hidden else "")


def _determined_cell(s) -> str:
    value, reason = determined_translation(s)
    return NOT_MEASURED if reason else _fmt(value, 100, 2)


def _not_measured_notes(solvers) -> list[str]:
    """One footnote per reason a number of the table is shown as :data:`NOT_MEASURED`."""
    ok = [s for s in solvers if s.X is not None]
    notes = []
    projected = [s.label for s in ok if determined_translation(s)[1]]
    if projected:
        notes.append(f"{NOT_MEASURED} in 'determined [cm]' [{', '.join(projected)}]: "
                     f"{REASON_ALL_PROJECTED}")
    infinite = [s.label for s in ok if _sigma_reason(s.sigma_rotation_deg)
                or _sigma_reason(s.sigma_translation_m)]
    if infinite:
        notes.append(f"{NOT_MEASURED} as σ [{', '.join(infinite)}]: {REASON_SIGMA_INFINITE}")
    return notes


def summary_table(result) -> str:
    """Console summary: one row per solver (error ± predicted 1-sigma, runtime, verdict;
    FAILED rows with the reason), the flagged directions beneath, the data-chosen alpha and
    the oracle alpha (labelled: it uses the ground truth), then pose-source errors and
    pairing counts."""
    head = ["method", "alpha", "rot err ± σ [deg]", "trans err ± σ [cm]", "determined [cm]",
            "time [ms]", "verdict"]
    rows = []
    for s in result.solvers:
        if s.X is None:
            rows.append([s.label, f"FAILED: {s.error or 'no estimate'}"])
            continue
        rows.append([s.label, _fmt(s.alpha, digits=3),
                     _pm(s.rotation_error_deg, s.sigma_rotation_deg, 1.0, 3),
                     _pm(s.translation_error_m, s.sigma_translation_m, 100, 2),
                     _determined_cell(s),
                     _fmt(s.runtime_s, 1e3, 2), _verdict_cell(s)])
    full = [r for r in rows if len(r) == len(head)]
    widths = [max(len(h), *(len(r[i]) for r in full)) if full else len(h)
              for i, h in enumerate(head)]
    widths[0] = max([widths[0]] + [len(r[0]) for r in rows])
    line = "  ".join(h.ljust(w) if i in (0, len(head) - 1) else h.rjust(w) for i, (h, w) in
                     enumerate(zip(head, widths)))
    out = [f"scenario {result.config.scenario!r} (source={result.config.source}, "
           f"seed={result.config.seed}, {result.pairing.get('used', '?')} motions)",
           line, "-" * len(line)]
    for r in rows:
        if len(r) != len(head):  # a failed solver: its reason instead of numbers
            out.append(f"{r[0].ljust(widths[0])}  {r[1]}")
            continue
        out.append("  ".join(c.ljust(w) if i in (0, len(head) - 1) else c.rjust(w)
                             for i, (c, w) in enumerate(zip(r, widths))))
    undet = {}
    for s in result.solvers:
        if s.X is None or not s.degenerate:
            continue
        undet.setdefault(tuple(s.verdict_directions or s.undetermined), []).append(s.label)
    for dirs, labels in undet.items():
        out.append(f"not determined within tolerance [{', '.join(labels)}]: " + "; ".join(dirs))
    if undet:
        out.append("  -> along an undetermined direction the estimate is arbitrary (its error "
                   "is not a measurement); 'determined [cm]' = the translation error with the "
                   "flagged translation directions that no prior fixed projected out")
    out += _not_measured_notes(result.solvers)
    choice = next((s.alpha_choice for s in result.solvers if s.alpha_choice), None)
    if choice:
        out.append(f"alpha = {_fmt(choice['alpha'], digits=3)} ({choice['source']}: "
                   f"{choice['how']})")
    orc = [s for s in result.solvers if s.oracle]
    if orc:
        out.append("oracle_alpha (USES THE GROUND TRUTH, for comparison only): " + "; ".join(
            f"{s.label} alpha {_fmt(s.oracle['oracle_alpha'], digits=3)}: "
            f"{_fmt(s.oracle['rotation_error_deg'], digits=3)} deg / "
            f"{_fmt(s.oracle['translation_error_m'], 100, 2)} cm" for s in orc))
    if getattr(result, "solver_kernels", "compiled") == "interpreted":
        from simcalib.kernel_mode import INTERPRETED_NOTE
        out.append(INTERPRETED_NOTE)
    fr = result.frames or {}
    if fr.get("rendered"):
        cams = []
        for cam in result.camera_names:
            c = fr.get(cam) or {}
            reasons = ", ".join(f"{k} {v}" for k, v in (c.get("drop_reasons") or {}).items())
            cams.append(f"{cam} used {c.get('used')}, dropped {c.get('dropped')}"
                        + (f" ({reasons})" if reasons else ""))
        n = {(fr.get(cam) or {}).get("frames") for cam in result.camera_names}
        head = (f"{fr['rendered']} per camera" if len(n) == 1 else "per camera "
                + ", ".join(f"{cam} {(fr.get(cam) or {}).get('frames')}"
                            for cam in result.camera_names))
        out.append(f"frames: {head}; " + "; ".join(cams))
    p = result.pairing or {}
    if p.get("candidate_pairs") is not None and p.get("matched") is not None:
        out.append(f"motion pairs: {p.get('used')} used of {p.get('candidate_pairs')} "
                   f"candidates (pre-filter dropped {p.get('dropped_translation')} for "
                   f"translation, {p.get('dropped_rotation')} for rotation; "
                   f"{p.get('dropped_time_diff')} datapoints for timestamp difference)")
    if result.pose_errors:
        parts = []
        for cam, e in result.pose_errors.items():
            sm = e.summary()
            if sm["n"]:
                parts.append(f"{cam}: median {_fmt(sm['rotation_deg']['median'], digits=3)} deg "
                             f"/ {_fmt(sm['translation_m']['median'], 1000, 2)} mm, p95 "
                             f"{_fmt(sm['rotation_deg']['p95'], digits=3)} deg / "
                             f"{_fmt(sm['translation_m']['p95'], 1000, 2)} mm")
        if parts:
            src = next(iter(result.pose_errors.values())).source
            out.append(f"pose error of source '{src}' vs ground truth: " + "; ".join(parts))
    return "\n".join(out)


def progress(iterable: Iterable | None = None, *, enabled: bool = True, **kw):
    """A tqdm progress bar on stderr; off when disabled or when stderr is not a terminal
    (so logs and pipes stay clean)."""
    from tqdm.auto import tqdm
    return tqdm(iterable, disable=None if enabled else True, file=sys.stderr,
                dynamic_ncols=True,
                leave=False, **kw)


def progress_line(text: str, *, enabled: bool = True) -> None:
    """One progress line on stderr where :func:`progress` shows no bar (stderr is not a
    terminal: logs, CI, pipes), so a long run still says where it is."""
    if enabled and not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        print(f"[simcalib] {text}", file=sys.stderr, flush=True)


_FRAME_PROGRESS: contextvars.ContextVar = contextvars.ContextVar("simcalib_frame_progress",
                                                                default=None)


def frame_progress():
    """The ``(n_done, n_total)`` frame callback of the run stage in progress (set by
    :func:`stage_frames`), or None outside a run or with progress off."""
    return _FRAME_PROGRESS.get()


class _StageFrames:
    """Frames done within one stage: moves the stage bar by the stage's share (a tty) or
    prints a line per tenth of the frames (logs, pipes) — never one line per frame."""

    def __init__(self, bar, stage: str, n_before: int, enabled: bool):
        self.bar, self.stage, self.n_before, self.enabled = bar, stage, n_before, enabled
        self._tenth = 0

    def __call__(self, n_done: int, n_total: int) -> None:
        if n_total <= 0:
            return
        frac = min(max(n_done / n_total, 0.0), 1.0)
        if not getattr(self.bar, "disable", True):
            self.bar.n = self.n_before + frac
            self.bar.set_postfix_str(f"frames {n_done}/{n_total}", refresh=True)
        tenth = int(10 * frac)
        if tenth > self._tenth:
            self._tenth = tenth
            progress_line(f"{self.stage}: frames {n_done}/{n_total} ({100 * frac:.0f} %)",
                          enabled=self.enabled)


@contextlib.contextmanager
def stage_frames(bar, stage: str, n_before: int, *, enabled: bool = True):
    """While the block runs, :func:`frame_progress` reports frames of ``stage`` (the
    ``n_before``-th stage) on ``bar`` and, off a terminal, as throttled lines."""
    token = _FRAME_PROGRESS.set(_StageFrames(bar, stage, n_before, enabled) if enabled
                                else None)
    try:
        yield
    finally:
        _FRAME_PROGRESS.reset(token)
        if not getattr(bar, "disable", True):
            bar.n = n_before
            bar.set_postfix_str("", refresh=False)
