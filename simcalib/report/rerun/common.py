"""What every recording shares: colours, entity names, number formats, orbital eyes and
how a self-contained recording is opened (headless, no viewer, no log-time timeline)."""

from __future__ import annotations

import math
import re
import uuid

import numpy as np

__all__ = ["entity_name", "CAMERA_COLORS", "SOLVER_COLORS", "TRUE_COLOR", "OFFSCALE_COLOR",
           "LABEL_COLOR", "SCENE_BACKGROUND", "CLOSEUP_BACKGROUND", "fmt", "fmt_len_cm",
           "fmt_len_m", "log_bar", "decades", "orbital_eye", "open_recording", "axis_name",
           "wrap", "panel_tail", "eye_controls"]


def entity_name(label: str) -> str:
    """Entity-path-safe name of a solver label (``dqopt+prior`` -> ``dqopt_prior``)."""
    return re.sub(r"[^A-Za-z0-9_]", "_", label)


CAMERA_COLORS = {"cam_a": (230, 120, 30), "cam_b": (40, 140, 230)}
SOLVER_COLORS = [(220, 50, 50), (50, 170, 80), (150, 80, 200), (240, 180, 0),
                 (0, 170, 190), (200, 100, 150), (120, 120, 120), (90, 60, 20)]
TRUE_COLOR = (40, 140, 230)
OFFSCALE_COLOR = (255, 40, 40)
LABEL_COLOR = (255, 255, 255)
#: backgrounds of the run recording's two 3D views (the screenshot checks rely on them)
SCENE_BACKGROUND = (245, 245, 245)
CLOSEUP_BACKGROUND = (28, 30, 34)    # label text (drawn on the viewer's grey label boxes)


def fmt_len_cm(x_m: float | None) -> str:
    if x_m is None or not np.isfinite(x_m):
        return "–"
    cm = 100.0 * float(x_m)
    return f"{cm:.3g} cm" if abs(cm) < 1e4 else f"{cm:.3g} cm ({x_m:.3g} m)"


def fmt_len_m(x_m: float) -> str:
    return f"{100 * x_m:.2g} cm" if x_m < 1.0 else f"{x_m:.2g} m"


def fmt(x, digits=3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    x = float(x)
    return f"{x:.{digits}g}" if abs(x) < 1e4 and (x == 0 or abs(x) >= 1e-3) else f"{x:.2e}"


def log_bar(value: float | None, lo: float, hi: float, width: int = 12) -> str:
    """A log-scale bar (unicode blocks) of ``value`` between decades ``lo`` and ``hi``."""
    if value is None or not np.isfinite(value) or value <= 0:
        return ""
    f = (math.log10(value) - lo) / max(hi - lo, 1e-9)
    n = int(round(min(max(f, 0.0), 1.0) * width))
    return "█" * max(n, 1)


def decades(values) -> tuple[float, float]:
    v = np.array([x for x in values if x is not None and np.isfinite(x) and x > 0])
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = math.floor(math.log10(v.min())), math.ceil(math.log10(v.max()))
    return float(lo), float(max(hi, lo + 1))


def orbital_eye(bbox_min, bbox_max, direction, up, inside=None, min_dist=0.0,
                distance: float = 1.3) -> dict:
    """An orbital eye looking at the centre of a box from ``direction``, ``distance`` box
    diagonals away (at least ``min_dist``; kept inside the box ``inside`` = (min, max) when
    given): ``{"position", "look_target", "eye_up"}``."""
    lo, hi = np.asarray(bbox_min, float), np.asarray(bbox_max, float)
    c = 0.5 * (lo + hi)
    ext = max(float(np.linalg.norm(hi - lo)), 0.05)
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    pos = c + max(distance * ext, min_dist) * d
    if inside is not None:
        pos = np.clip(pos, np.asarray(inside[0]) + 0.05, np.asarray(inside[1]) - 0.05)
    return {"position": pos.tolist(), "look_target": c.tolist(), "eye_up": list(up)}


def eye_controls(rrb, e: dict | None):
    """``rrb.EyeControls3D`` of an :func:`orbital_eye` (None: the viewer's own)."""
    return None if e is None else rrb.EyeControls3D(
        kind=rrb.Eye3DKind.Orbital, position=e["position"], look_target=e["look_target"],
        eye_up=e["eye_up"])


def panel_tail(rrb, time_panel, hidden: bool = False) -> tuple:
    """The panels a layout closes with: ``time_panel``, the blueprint and selection panels
    collapsed (``hidden``: those and the top panel hidden, for a view alone)."""
    state = "hidden" if hidden else "collapsed"
    out = (time_panel, rrb.BlueprintPanel(state=state), rrb.SelectionPanel(state=state))
    return out + ((rrb.TopPanel(state="hidden"),) if hidden else ())


def open_recording(rr, application_id: str, path, **save_kwargs):
    """A new in-process recording stream (unique recording id, no log-time timeline)
    saving to ``path``."""
    rec = rr.RecordingStream(application_id, recording_id=str(uuid.uuid4()),
                             send_properties=False)
    if hasattr(rec, "set_log_time_enabled"):
        rec.set_log_time_enabled(False)
    rec.save(str(path), **save_kwargs)
    return rec


def axis_name(v) -> str:
    """``x``/``y``/``z`` for a direction (nearly) along a camera-a axis, else the vector."""
    v = np.asarray(v, dtype=np.float64)
    i = int(np.argmax(np.abs(v)))
    if abs(v[i]) > 0.95:
        return "xyz"[i]
    return "(" + ", ".join(f"{x:+.2f}" for x in v) + ")"


def wrap(text: str, width: int = 34) -> list[str]:
    """``text`` (comma-separated names) wrapped after commas into lines of ~``width``."""
    lines, cur = [], ""
    for part in text.split(", "):
        if cur and len(cur) + 2 + len(part) > width:
            lines.append(cur + ",")
            cur = part
        else:
            cur = f"{cur}, {part}" if cur else part
    return lines + [cur]
