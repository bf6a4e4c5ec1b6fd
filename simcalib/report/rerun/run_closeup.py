"""A run recording's extrinsic close-up (entities ``closeup/...``, camera a's OpenCV frame:
x right, y down, z forward): camera a, the true camera b, every successful estimate as
axes with its 3-sigma translation ellipsoid, off-scale markers at the bound for wild ones,
and labels laid out on the view's screen (:func:`simcalib.report.rerun.labels.place_labels`).
Mixed into :class:`~simcalib.report.rerun.run.RunRecorder`."""

from __future__ import annotations

import numpy as np

from simcalib.geometry import quat_from_matrix
from simcalib.report.rerun.common import (
    CAMERA_COLORS,
    LABEL_COLOR,
    OFFSCALE_COLOR,
    SOLVER_COLORS,
    TRUE_COLOR,
    axis_name,
    entity_name,
    fmt,
    fmt_len_cm,
    fmt_len_m,
    orbital_eye,
    wrap,
)
from simcalib.report.rerun.labels import layout_labels

__all__ = ["CloseupLogging", "closeup_bound_m"]


def closeup_bound_m(t_true_norm_m: float) -> float:
    """Radius of the extrinsic close-up around camera a: ``min(1 m, 10 |t_X|)``, at least
    0.1 m. Estimates beyond it are drawn at the bound as off-scale markers."""
    return float(max(0.1, min(1.0, 10.0 * float(t_true_norm_m))))


def _add_to_group(groups: list, item, where, radius: float) -> None:
    """Append ``item`` to the first group whose first member lies within ``radius`` of
    ``where`` (members are tuples whose second entry is their place), else a new group."""
    for grp in groups:
        if np.linalg.norm(grp[0][1] - where) < radius:
            grp.append(item)
            return
    groups.append([item])


def _group_lines(grp, notes: dict) -> list[str]:
    """A group's label: its names (wrapped), then the uncertainty notes (once when every
    member has the same, else each prefixed with its solver)."""
    names = [s.label for s, _, _ in grp]
    lines = wrap(", ".join(names))
    same = len({tuple(notes.get(n, [])) for n in names}) == 1
    for n in names[:1] if same else names:
        lines += [x if same else f"{n}: {x}" for x in notes.get(n, [])]
    return lines


def _closeup_labels(failed, t_true, groups, offscale, notes, bound) -> list[tuple]:
    """The close-up's labels: ``(key, anchor, lines, leader colour)``."""
    cam_lines = ["cam a (origin)"]
    if failed:
        cam_lines.append("FAILED, not drawn: " + ", ".join(s.label for s in failed))
    labels = [("cam_a", np.zeros(3), cam_lines, CAMERA_COLORS["cam_a"]),
              ("true_cam_b", t_true, ["true cam b"], TRUE_COLOR)]
    labels += [(f"{j}", grp[0][1], _group_lines(grp, notes), grp[0][2])
               for j, grp in enumerate(groups)]
    for j, grp in enumerate(offscale):   # the real errors of what is drawn at the bound
        labels.append((f"offscale_{j}", grp[0][1],
                       [f"OFF-SCALE (drawn at {bound:g} m), real error:"]
                       + [f"{s.label}: {fmt(s.rotation_error_deg)}° / "
                          f"{fmt_len_cm(s.translation_error_m)}" for s, _ in grp],
                       OFFSCALE_COLOR))
    return labels


class CloseupLogging:
    """The close-up part of a run recording."""

    def log_estimates(self, solvers, X_true, gt: dict | None = None) -> None:
        """The extrinsic close-up (camera a frame) and the per-solver error scalars.

        Estimates that agree within ``0.3 L`` (L: the axis length) share one label listing
        their names; every label is placed on the screen of the close-up's eye
        (:func:`~simcalib.report.rerun.labels.place_labels`) so that no two labels
        overlap, each joined to what it names by a leader line. Estimates beyond
        :func:`closeup_bound_m` are drawn at the bound (off-scale); uncertainty ellipsoids
        are bounded the same way (:meth:`_log_ellipsoid`)."""
        X_true = np.asarray(X_true, dtype=np.float64)
        t_true = X_true[:3, 3]
        self.present.add("closeup")
        bound = closeup_bound_m(np.linalg.norm(t_true))
        L = float(np.clip(0.3 * np.linalg.norm(t_true), 0.02, 0.15))   # axis length
        ok = [s for s in solvers if s.X is not None and np.isfinite(s.X).all()]
        failed = [s for s in solvers if s not in ok]
        self._log_references(X_true, L)
        groups, offscale, notes = self._log_estimate_axes(ok, bound, L)
        extent = np.array([np.zeros(3), t_true] + [t for g in groups for _, t, _ in g]
                          + [g[0][1] for g in offscale])
        self.closeup_extent = extent
        self.closeup_eye = orbital_eye(extent.min(0) - L, extent.max(0) + L,
                                       (-0.35, -0.5, -1.0), (0, -1, 0))
        self._log_labels(_closeup_labels(failed, t_true, groups, offscale, notes, bound),
                         bound, L)
        for s in ok:
            self.rec.log(f"errors/{entity_name(s.label)}/rotation_deg",
                         self.rr.Scalars([s.rotation_error_deg]), static=True)
            self.rec.log(f"errors/{entity_name(s.label)}/translation_cm",
                         self.rr.Scalars([100.0 * s.translation_error_m]), static=True)

    def _log_references(self, X_true, L) -> None:
        """Camera a at the origin and the true camera b, as axes and dots."""
        rr = self.rr
        self.rec.log("closeup/cam_a", rr.TransformAxes3D(L), rr.Points3D(
            [[0.0, 0.0, 0.0]], radii=0.1 * L, colors=CAMERA_COLORS["cam_a"]), static=True)
        self._log_pose("closeup/true_cam_b", X_true, static=True)
        self.rec.log("closeup/true_cam_b", rr.TransformAxes3D(1.3 * L), rr.Points3D(
            [[0.0, 0.0, 0.0]], radii=0.12 * L, colors=TRUE_COLOR), static=True)

    def _log_estimate_axes(self, ok, bound, L):
        """Each successful estimate as axes (with its ellipsoid when it has a covariance),
        or at the bound when it lies beyond it. Returns ``(groups, offscale, notes)``: the
        estimates drawn, grouped when on top of each other (``(s, t, colour)``), the
        off-scale ones grouped by place (``(s, p)``), and each solver's uncertainty notes."""
        rr = self.rr
        groups: list[list] = []
        offscale: list[list] = []
        notes: dict[str, list[str]] = {}
        for k, s in enumerate(ok):
            t = np.asarray(s.X)[:3, 3]
            color = SOLVER_COLORS[k % len(SOLVER_COLORS)]
            if np.linalg.norm(t) > bound:
                p = t / np.linalg.norm(t) * bound
                _add_to_group(offscale, (s, p), p, 0.3 * L)
                continue
            ent = f"closeup/estimates/{entity_name(s.label)}"
            self._log_pose(ent, np.asarray(s.X), static=True)
            self.rec.log(ent, rr.TransformAxes3D(L), rr.Points3D(
                [[0.0, 0.0, 0.0]], radii=0.08 * L, colors=color), static=True)
            _add_to_group(groups, (s, t, color), t, 0.3 * L)
            cov = getattr(s, "covariance", None)
            if cov is not None:
                notes[s.label] = self._log_ellipsoid(
                    f"closeup/uncertainty/{entity_name(s.label)}", np.asarray(cov), t, bound,
                    L, color, s.label)
        for j, grp in enumerate(offscale):
            p = grp[0][1]
            self.rec.log(f"closeup/offscale/{j}", rr.Points3D(
                [p], radii=0.2 * L, colors=OFFSCALE_COLOR), rr.Arrows3D(
                origins=[0.85 * p], vectors=[0.15 * p], colors=OFFSCALE_COLOR), static=True)
        return groups, offscale, notes

    def _log_labels(self, labels, bound, L) -> None:
        """The labels at their places on the close-up's screen, with a leader line to what
        each names when it had to move away."""
        rr = self.rr
        placed = layout_labels(self.closeup_eye, [(a, lines) for _, a, lines, _ in labels],
                               max_norm=1.4 * bound)
        for (key, anchor, lines, color), (p, end) in zip(labels, placed):
            leader = None   # to the label's nearest edge (never across the text)
            if np.linalg.norm(p - anchor) > 0.2 * L:
                leader = rr.LineStrips3D([[anchor, end]], colors=color, radii=0.006 * L)
            self.rec.log(f"closeup/labels/{key}", *[a for a in (rr.Points3D(
                [p], radii=0.02 * L, colors=LABEL_COLOR, labels=["\n".join(lines)]), leader)
                if a is not None], static=True)

    def _log_ellipsoid(self, ent, cov, center, bound, L, color, label) -> list[str]:
        """The 3-sigma ellipsoid of the translation block (rows/cols 3..5 of the 6x6
        covariance of (omega, v) in frame a), bounded like the estimates: a half-axis is
        clipped so the ellipsoid stays inside the close-up's bound (a red arrow at each
        clipped end marks it off-scale); an undetermined (infinite) axis is no part of the
        ellipsoid but a red double arrow through the estimate. Returns the label notes
        (e.g. ``3σ 1.4 m along y: off-scale``, ``σ = ∞ along x, y, z``)."""
        rr = self.rr
        C = np.asarray(cov, dtype=np.float64)
        if C.shape != (6, 6):
            return []
        Ct = 0.5 * (C[3:, 3:] + C[3:, 3:].T)
        inf_axes = ~np.isfinite(np.diag(Ct)) | (np.diag(Ct) > 1e12)
        # principal axes of the determined coordinates; the undetermined ones as they are
        fin = np.flatnonzero(~inf_axes)
        sub = np.where(np.isfinite(Ct), Ct, 0.0)[np.ix_(fin, fin)]
        w_f, V_f = np.linalg.eigh(sub) if fin.size else (np.zeros(0), np.zeros((0, 0)))
        w, V = np.zeros(3), np.zeros((3, 3))
        w[:fin.size] = w_f
        V[np.ix_(fin, np.arange(fin.size))] = V_f
        V[np.flatnonzero(inf_axes), np.arange(fin.size, 3)] = 1.0
        undetermined = np.arange(3) >= fin.size
        if np.linalg.det(V) < 0:
            V[:, 0] = -V[:, 0]
        half_real = 3.0 * np.sqrt(np.clip(w, 0.0, None))
        cap = max(bound - float(np.linalg.norm(center)), 0.25 * bound)
        clipped = ~undetermined & (half_real > cap)
        half = np.where(undetermined, 0.0, np.minimum(half_real, cap))
        notes, arrows_o, arrows_v = [], [], []
        for i in np.flatnonzero(clipped):
            notes.append(f"3σ {fmt_len_m(half_real[i])} along {axis_name(V[:, i])}: "
                         f"off-scale (drawn at {fmt_len_m(cap)})")
            for sgn in (1.0, -1.0):
                arrows_o.append(center + sgn * cap * V[:, i])
                arrows_v.append(sgn * 0.6 * L * V[:, i])
        if undetermined.any():
            notes.append("σ = ∞ along " + ", ".join(axis_name(V[:, i])
                                                     for i in np.flatnonzero(undetermined)))
            for i in np.flatnonzero(undetermined):
                for sgn in (1.0, -1.0):
                    arrows_o.append(center + sgn * 0.3 * L * V[:, i])
                    arrows_v.append(sgn * 1.2 * L * V[:, i])
        sigma = np.sqrt(np.clip(np.diag(Ct), 0, None))
        text = (f"{label} 3σ: σ = " + ", ".join("∞" if u else f"{100 * v:.2g}"
                                                 for u, v in zip(inf_axes, sigma)) + " cm")
        if not undetermined.all():
            self.rec.log(ent, rr.Ellipsoids3D(
                centers=[center], half_sizes=[np.maximum(half, 1e-4)],
                quaternions=[quat_from_matrix(V)], colors=[(*color, 90)],
                fill_mode="transparentfillmajorwireframe", labels=[text], show_labels=False),
                static=True)
        if arrows_o:
            self.rec.log(f"{ent}/offscale", rr.Arrows3D(
                origins=arrows_o, vectors=arrows_v, colors=OFFSCALE_COLOR,
                radii=0.02 * L, labels=[text] * len(arrows_o), show_labels=False),
                static=True)
        return notes

    def _log_pose(self, entity: str, T: np.ndarray, static: bool = False) -> None:
        rr = self.rr
        self.rec.log(entity, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                     static=static)
