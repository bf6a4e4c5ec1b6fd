"""Labels laid out on a 3D view's screen: none overlaps another."""

from __future__ import annotations

import numpy as np

from simcalib.report.rerun.labels import CHAR_W, LINE_H, place_labels, screen_basis


def test_closeup_labels_do_not_overlap_on_screen():
    eye = {"position": [-0.7, -0.8, -2.0], "look_target": [0.0, 0.2, 0.0],
           "eye_up": [0, -1, 0]}
    rng = np.random.default_rng(0)
    items = [(np.array([0.0, 0.28, 0.0]) + 0.01 * rng.standard_normal(3), [f"label {k}"])
             for k in range(6)] + [(np.zeros(3), ["cam a (origin)", "FAILED: x"])]
    pts = place_labels(eye, items, max_norm=1.4)
    pos, f, r, u = screen_basis(eye)
    boxes = []
    for p, (_, lines) in zip(pts, items):
        d = p - pos
        x, y = d @ r / (d @ f), -(d @ u) / (d @ f)
        w, h = max(map(len, lines)) * CHAR_W, len(lines) * LINE_H
        boxes.append((x - w / 2, y, x + w / 2, y + h))
        assert np.linalg.norm(p) <= 1.4 + 1e-9
    for i, a in enumerate(boxes):
        for b in boxes[:i]:
            assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3])


def test_leaders_end_at_the_label_edge_nearest_the_anchor():
    """A leader runs from its anchor to the label's nearest edge, never across the text
    (it ended at the text's top and crossed a label placed above its anchor)."""
    from simcalib.report.rerun.labels import PAD, label_size, layout_labels, project
    eye = {"position": [-1.0, -1.3, 1.1], "look_target": [0.0, 0.0, 0.0], "eye_up": [0, 0, 1]}
    items = [(np.array([0.01 * k, 0.0, 0.0]), [f"stop {k}"]) for k in range(6)]
    for (anchor, lines), (p, end) in zip(items, layout_labels(eye, items)):
        (px, py), _ = project(eye, p)
        w, h = label_size(lines)
        box = (px - w / 2, py + 0.005, px + w / 2, py + 0.005 + h)   # the text below its point
        (ax, ay), _ = project(eye, anchor)
        (ex, ey), _ = project(eye, end)
        assert box[0] - 1e-9 <= ex <= box[2] + 1e-9 and box[1] - 1e-9 <= ey <= box[3] + 1e-9
        inside = box[0] < ax < box[2] and box[1] < ay < box[3]
        mx, my = 0.5 * (ax + ex), 0.5 * (ay + ey)        # the leader's middle: off the text
        assert inside or not (box[0] + PAD < mx < box[2] - PAD and box[1] + PAD < my < box[3]
                              - PAD)
