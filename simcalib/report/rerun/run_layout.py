"""The layouts (blueprints) a run recording opens on, per scenario kind, and the layouts of
one view alone (the screenshot tool's close-up and scene checks)."""

from __future__ import annotations

from simcalib.report.rerun.common import (
    CLOSEUP_BACKGROUND,
    SCENE_BACKGROUND,
    eye_controls,
    panel_tail,
)

__all__ = ["default_blueprint", "single_view_blueprint", "VIEWS"]

#: the views of a run recording a layout may hold (``present`` of :func:`default_blueprint`)
VIEWS = ("scene", "closeup", "pose_error", "summary")


def _views(rrb, eye, closeup_eye, cameras) -> dict:
    """Every view of the run layouts, by name (``images``: one per camera)."""
    return {
        "scene": rrb.Spatial3DView(
            origin="world", name="scene (true paths: lines, pose source: points)",
            eye_controls=eye_controls(rrb, eye), background=SCENE_BACKGROUND,
            line_grid=rrb.LineGrid3D(visible=False)),
        "closeup": rrb.Spatial3DView(
            origin="closeup", name="extrinsic close-up (camera a frame; true cam_b blue)",
            eye_controls=eye_controls(rrb, closeup_eye), background=CLOSEUP_BACKGROUND,
            line_grid=rrb.LineGrid3D(visible=False)),
        "pose_error": [rrb.TimeSeriesView(origin="pose_error/rotation_deg",
                                          name="pose-source rotation error [deg]"),
                       rrb.TimeSeriesView(origin="pose_error/translation_mm",
                                          name="pose-source translation error [mm]")],
        "summary": rrb.TextDocumentView(origin="summary",
                                        name="summary: errors per solver (log bars), verdict"),
        "images": [rrb.Spatial2DView(origin=f"world/{c}/image", name=f"{c} image + detections")
                   for c in cameras],
    }


def _box(rrb, cls, items, shares):
    """``cls`` (Horizontal / Vertical) of the ``items`` that are not None with their
    ``shares``; the item itself when only one is left, None when none is."""
    kept = [(i, sh) for i, sh in zip(items, shares) if i is not None]
    if not kept:
        return None
    if len(kept) == 1:
        return kept[0][0]
    key = "row_shares" if cls is rrb.Vertical else "column_shares"
    return cls(*[i for i, _ in kept], **{key: [sh for _, sh in kept]})


def default_blueprint(kind: str = "sim", images: bool = True, cameras=("cam_a", "cam_b"),
                      eye: dict | None = None, closeup_eye: dict | None = None,
                      present: set | None = None, rrb=None):
    """The layout a run recording opens on, per scenario kind.

    Left: the scene (room, platform, cameras, trajectories) and, when images were logged
    (rendering sources), the images of ``cameras`` with that frame's detections. Right: the
    extrinsic close-up, the pose-source error (rotation and translation in separate plots)
    and the summary. Synthetic runs (no room, no images) give the scene less room and the
    tables more. ``eye`` / ``closeup_eye``: ``{"position", "look_target", "eye_up"}`` of the
    two 3D views. ``present``: the views that have data (:data:`VIEWS`); the others are
    left out (no pane says "No data available"); ``None`` keeps all. ``rrb``:
    ``rerun.blueprint`` (default) or the recorder's stand-in for it."""
    if rrb is None:
        import rerun.blueprint as rrb
    v = _views(rrb, eye, closeup_eye, cameras if images else ())
    if present is not None:   # only views with data (an interrupted run has fewer)
        v = {k: (x if k in present or k == "images" else ([] if k == "pose_error" else None))
             for k, x in v.items()}
    V, H = rrb.Vertical, rrb.Horizontal
    pose = _box(rrb, V, v["pose_error"], [1] * len(v["pose_error"]))
    scene, closeup, summary = v["scene"], v["closeup"], v["summary"]
    if kind == "synthetic":
        body = _box(rrb, H, [_box(rrb, V, [scene, closeup], [1, 1]),
                             _box(rrb, V, [pose, summary], [2, 3])], [2, 3])
    elif v["images"]:
        body = _box(rrb, H, [
            _box(rrb, V, [scene, _box(rrb, H, v["images"], [1] * len(v["images"]))], [3, 2]),
            _box(rrb, V, [_box(rrb, H, [closeup, pose], [3, 2]), summary], [1, 1])], [1, 1])
    else:
        body = _box(rrb, H, [_box(rrb, V, [scene, closeup], [3, 2]),
                             _box(rrb, V, [pose, summary], [2, 3])], [1, 1])
    if body is None:
        body = rrb.Spatial3DView(origin="world", name="scene")
    return rrb.Blueprint(body, *panel_tail(rrb, rrb.TimePanel(timeline="frame",
                                                              state="collapsed")),
                         auto_views=False)


def single_view_blueprint(which: str, eye: dict | None, rrb=None):
    """A layout of one 3D view of a run recording alone (``which``: ``"closeup"`` or
    ``"scene"``), with ``eye``, every panel hidden."""
    if which not in ("closeup", "scene"):
        raise ValueError(f"which must be 'closeup' or 'scene'; received {which!r}")
    if rrb is None:
        import rerun.blueprint as rrb
    view = rrb.Spatial3DView(
        origin="closeup" if which == "closeup" else "world", name=which,
        eye_controls=eye_controls(rrb, eye), line_grid=rrb.LineGrid3D(visible=False),
        background=CLOSEUP_BACKGROUND if which == "closeup" else SCENE_BACKGROUND)
    return rrb.Blueprint(view, *panel_tail(rrb, rrb.TimePanel(state="hidden"), hidden=True),
                         auto_views=False)
