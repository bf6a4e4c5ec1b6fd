"""The advice recording (advice.rrd) read back: a layout of its own, the stops and the
reference inside the 3D view, stop labels that do not overlap on its screen, rotation [deg]
and translation [cm] in plots of their own, the summary's stops from the previous one."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from rrd_reading import chunks

from simcalib.geometry import matrix_from_rotvec
from simcalib.report.rerun.advice import VIEW_ASPECT, record_recorded_advice
from simcalib.report.rerun.labels import CHAR_W, FOV_TAN, LINE_H, project


def _pose(rotvec, t):
    T = np.eye(4)
    T[:3, :3] = matrix_from_rotvec(np.asarray(rotvec, dtype=float))
    T[:3, 3] = t
    return T


def _advice(k=6):
    """Advice on files whose sensor a moved on a 1 m circle; ``k`` stops close together
    (their labels would overlap where they stand) and one far off."""
    rng = np.random.default_rng(0)
    s = np.linspace(0, 2 * np.pi, 100)
    T_a = np.stack([_pose([0, 0, 0.5 * np.sin(x)], [np.cos(x), np.sin(x), 0]) for x in s])
    motions = np.stack([_pose(rng.normal(0, 0.3, 3), [0.02 * j, 0.01 * j, 0.01])
                        for j in range(k - 1)] + [_pose([0, 0, 1.0], [0.5, -1.5, 0.6])])
    std_before = np.array([0.5, 0.6, np.inf, 0.02, np.inf, 0.2])
    after = [std_before * 0.5 ** (j + 1) for j in range(k)]
    for a in after:
        a[~np.isfinite(a)] = 0.03
    adv = SimpleNamespace(T_ref_a=T_a[-1], motion_a=motions, chosen=np.arange(k),
                          X=_pose([0.1, 0.0, 0.2], [0.05, -0.1, 0.02]), std_before=std_before,
                          std_after=after)
    std = lambda v: {f"{a}_{u}": (None if not np.isfinite(x) else float(x))  # noqa: E731
                     for (a, u), x in zip([("wx", "deg"), ("wy", "deg"), ("wz", "deg"),
                                           ("vx", "m"), ("vy", "m"), ("vz", "m")], v)}
    out = {"predicted_std_before": std(std_before), "motions": [
        {"step": j + 1, "predicted_std_after": std(after[j]), "sensor_motions": {
            "a": {"angle_deg": 10.0 + j, "translation_m": [0.1, 0.0, 0.0]}}}
        for j in range(k)]}
    return T_a, adv, out


def _origins(bp) -> dict:
    out, stack = {}, [bp.root_container]
    while stack:
        c = stack.pop()
        if hasattr(c, "contents") and not hasattr(c, "origin"):
            stack.extend(c.contents)
        else:
            out[str(c.origin)] = str(c.name)
    return out


def test_advice_recording_layout_framing_labels_and_units(tmp_path):
    from rerun.chunk import RrdReader

    from simcalib.report.rerun.advice import advice_blueprint
    T_a, adv, out = _advice()
    p = record_recorded_advice(tmp_path / "advice.rrd", T_a, adv, out, background=False)
    assert RrdReader(str(p)).blueprints()
    eye = json.loads((tmp_path / "advice_view.json").read_text())["eye"]
    views = _origins(advice_blueprint(eye))
    assert {"world", "advice/log10_std_deg", "advice/log10_std_cm", "advice/summary"} \
        <= set(views)
    assert "[deg]" in views["advice/log10_std_deg"] and "[cm]" in views["advice/log10_std_cm"]
    ents = chunks(p)
    # degrees and centimetres never share a plot; an infinite sigma is left out
    rot = {e for e in ents if e.startswith("/advice/log10_std_deg/")}
    tr = {e for e in ents if e.startswith("/advice/log10_std_cm/")}
    assert rot == {f"/advice/log10_std_deg/{a}" for a in ("wx", "wy", "wz")}
    assert tr == {f"/advice/log10_std_cm/{a}" for a in ("vx", "vy", "vz")}
    vx = np.ravel(ents["/advice/log10_std_cm/vx"]["Scalars:scalars"])
    np.testing.assert_allclose(vx, np.log10([2.0 * 0.5 ** j for j in range(7)]))
    assert len(np.ravel(ents["/advice/log10_std_deg/wz"]["Scalars:scalars"])) == 6
    # every stop, the reference and the recorded path inside the 3D view
    stops = adv.T_ref_a @ adv.motion_a[adv.chosen]
    pts = np.concatenate([stops[:, :3, 3], (stops @ adv.X)[:, :3, 3], T_a[:, :3, 3]])
    xy = np.array([project(eye, q)[0] for q in pts])
    assert (np.abs(xy[:, 0]) < 0.95 * FOV_TAN * VIEW_ASPECT).all()
    assert (np.abs(xy[:, 1]) < 0.95 * FOV_TAN).all()
    # one label per stop, none overlapping another on the view's screen
    boxes = []
    for k in range(len(stops)):
        c = ents[f"/world/advice/labels/{k + 1}"]
        assert c["Points3D:labels"] == [[f"stop {k + 1}"]] or \
            np.ravel(c["Points3D:labels"]).tolist() == [f"stop {k + 1}"]
        (x, y), _ = project(eye, np.ravel(c["Points3D:positions"])[:3])
        w = len(f"stop {k + 1}") * CHAR_W
        boxes.append((x - w / 2, y, x + w / 2, y + LINE_H))
    for i, a in enumerate(boxes):
        for b in boxes[:i]:
            assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3])
    md = str(np.ravel(ents["/advice/summary"]["TextDocument:text"])[0])
    assert "from the previous stop" in md and "| + stop 6 |" in md and "| — |" in md


@pytest.mark.slow
def test_advice_screenshots(tmp_path):
    """The real viewer under Xvfb (advice for a planar rig's pose files): no empty pane,
    both units' plots and the summary read, every stop labelled, the stops framed."""
    from simcalib.tools.screenshots import check_advice, missing_prerequisites, run_advice
    missing = missing_prerequisites()
    if missing:
        pytest.skip("viewer screenshots need: " + "; ".join(missing))
    rep = check_advice(run_advice("files", tmp_path / "files"), tmp_path / "shots", "files")
    assert rep.ok, rep.problems
