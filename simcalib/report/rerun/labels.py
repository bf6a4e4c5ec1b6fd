"""Labels of a 3D view laid out on the view's screen so that none overlaps another nor a
labelled dot (the viewer draws a point's label centred just below it, at a fixed text size,
whatever the depth: overlaps are decided on the screen, not in 3D).

Sizes are in tangent units of the viewer's 3D eye (vertical field of view 55°: the view is
2 tan(27.5°) = 1.04 high), for the smallest pane a layout gives such a view (about 480 x
440 logical px: 15 px per text line, 6 px per character)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["place_labels", "layout_labels", "layout_boxes", "screen_basis", "project",
           "LINE_H", "CHAR_W", "PAD",
           "FOV_TAN", "PANE_ASPECT", "label_size"]

FOV_TAN = math.tan(math.radians(55.0) / 2)
LINE_H = 0.045
CHAR_W = 0.0145
PAD = 0.012
PANE_ASPECT = 1.05
_DOT = 0.012        # half size of a labelled dot on the screen


def screen_basis(eye: dict):
    """``(position, forward, right, up)`` unit vectors of an orbital eye."""
    pos = np.asarray(eye["position"], dtype=np.float64)
    f = np.asarray(eye["look_target"], dtype=np.float64) - pos
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(eye["eye_up"], dtype=np.float64))
    r /= np.linalg.norm(r)
    return pos, f, r, np.cross(r, f)


def project(eye: dict, p) -> tuple[np.ndarray, float]:
    """Screen coordinates (x right, y down, tangent units) and depth of point ``p``."""
    pos, f, r, u = screen_basis(eye)
    d = np.asarray(p, dtype=np.float64) - pos
    z = max(float(d @ f), 1e-6)
    return np.array([d @ r / z, -(d @ u) / z]), z


def label_size(lines) -> tuple[float, float]:
    """Width and height on the screen of a label of ``lines``."""
    return (max(len(x) for x in lines) * CHAR_W + 2 * PAD, len(lines) * LINE_H + PAD)


def _overlaps(b, others) -> bool:
    return any(b[0] < o[2] and o[0] < b[2] and b[1] < o[3] and o[1] < b[3] for o in others)


def _candidates(anchor_xy, size, half_w, half_h):
    """Boxes ``(x0, y0, x1, y1)`` for a label, nearest first: just above the anchor, below,
    beside (right, left), then ever farther away; each kept inside the pane."""
    (ax, ay), (w, h) = anchor_xy, size

    def box(cx, top):
        cx = float(np.clip(cx, -half_w + 0.5 * w, half_w - 0.5 * w)) if w < 2 * half_w \
            else 0.0
        top = float(np.clip(top, -half_h + 0.02, half_h - h - 0.02))
        return (cx - 0.5 * w, top, cx + 0.5 * w, top + h)

    above, below, mid = ay - _DOT - h, ay + _DOT, ay - 0.5 * h
    right, left = ax + 0.02 + 0.5 * w, ax - 0.02 - 0.5 * w
    for k in range(90):
        d = k * LINE_H / 3
        yield from (box(ax, above - d), box(ax, below + d), box(right, mid - d),
                    box(right, mid + d), box(left, mid - d), box(left, mid + d))


def layout_boxes(anchors_xy, sizes, aspect: float = PANE_ASPECT, avoid_xy=()) -> list[tuple]:
    """Screen boxes for labels of ``sizes`` at ``anchors_xy`` (screen points), placed
    greedily from the top anchor down: the first candidate (:func:`_candidates`) that
    overlaps neither a box placed before nor any anchor's dot nor a dot of ``avoid_xy``;
    in a crowded pane, below everything placed."""
    half_h, half_w = FOV_TAN, FOV_TAN * aspect
    dots = [(x - _DOT, y - _DOT, x + _DOT, y + _DOT)
            for x, y in list(anchors_xy) + list(avoid_xy)]
    boxes: list = [None] * len(sizes)
    for i in sorted(range(len(sizes)), key=lambda k: anchors_xy[k][1]):
        others = [b for b in boxes if b is not None] + [d for k, d in enumerate(dots)
                                                        if k != i]
        best = next((b for b in _candidates(anchors_xy[i], sizes[i], half_w, half_h)
                     if not _overlaps(b, others)), None)
        if best is None:
            (ax, ay), (w, h) = anchors_xy[i], sizes[i]
            top = max([o[3] for o in boxes if o is not None], default=ay) + 0.005
            best = (ax - 0.5 * w, top, ax + 0.5 * w, top + h)
        boxes[i] = best
    return boxes


def _onto_sphere(pos, ray, z, max_norm) -> np.ndarray:
    """The point at depth ``z`` along ``ray``, or nearer the eye on the same ray when that
    would leave the sphere of radius ``max_norm`` around the origin."""
    p = pos + z * ray
    if max_norm is None or np.linalg.norm(p) <= max_norm:
        return p
    aa, bb, cc = float(ray @ ray), float(pos @ ray), float(pos @ pos) - max_norm ** 2
    disc = bb * bb - aa * cc
    roots = [] if disc < 0 else [(-bb - math.sqrt(disc)) / aa, (-bb + math.sqrt(disc)) / aa]
    roots = [x for x in roots if 0 < x <= z]
    return pos + (max(roots) if roots else max(-bb / aa, 1e-3)) * ray


def layout_labels(eye: dict, items, max_norm: float | None = None,
                  aspect: float = PANE_ASPECT, avoid=()) -> list[tuple]:
    """``(point, attach)`` per label: the 3D point to log the label at, and where a leader
    line from its anchor should end — the point of the label's box nearest the anchor (a
    leader to ``point``, the top of the text, would cross a label placed above it).

    ``items``: ``(anchor (3,), lines)``. Each label is a box of its text's size in the
    viewer (:func:`label_size`) that the viewer centres horizontally just below its point;
    the boxes are laid out by :func:`layout_boxes` inside a pane of ``aspect`` (width over
    height), clear of the dots of ``avoid`` (3D points no label may cover). Both points are
    put on the anchor's viewing depth, or nearer the eye if that would leave the sphere of
    radius ``max_norm`` (None: no bound)."""
    pos, f, r, u = screen_basis(eye)
    anchors = [project(eye, a) for a, _ in items]
    boxes = layout_boxes([xy for xy, _ in anchors], [label_size(lines) for _, lines in items],
                         aspect, [project(eye, p)[0] for p in avoid])
    out = []
    for ((ax, ay), z), b in zip(anchors, boxes):
        sx, sy = 0.5 * (b[0] + b[2]), b[1] - 0.005   # text centred just below its point
        cx, cy = float(np.clip(ax, b[0], b[2])), float(np.clip(ay, b[1], b[3]))
        out.append((_onto_sphere(pos, f + sx * r - sy * u, z, max_norm),
                    _onto_sphere(pos, f + cx * r - cy * u, z, max_norm)))
    return out


def place_labels(eye: dict, items, max_norm: float | None = None,
                 aspect: float = PANE_ASPECT, avoid=()) -> list[np.ndarray]:
    """3D points for labels so that none overlaps another on the screen of ``eye`` (the
    ``point`` of :func:`layout_labels`)."""
    return [p for p, _ in layout_labels(eye, items, max_norm, aspect, avoid)]
