"""A run recording's plots: the pose-source error per frame (``pose_error/...``, one plot
per unit, a colour per camera) and each solver's error and predicted 1-sigma against the
number of motions used (``convergence/...``, timeline ``motions``)."""

from __future__ import annotations

import numpy as np

from simcalib.report.rerun.common import CAMERA_COLORS, SOLVER_COLORS, entity_name

__all__ = ["PlotLogging", "log_convergence"]


class PlotLogging:
    """The plots of a run recording (mixed into :class:`~simcalib.report.rerun.run.RunRecorder`)."""

    def log_pose_errors(self, pose_errors: dict) -> None:
        """One plot per unit (``pose_error/rotation_deg``, ``pose_error/translation_mm``),
        one named series per camera in the camera's colour."""
        rr = self.rr
        for cam, e in pose_errors.items():
            if e.n == 0:
                continue
            frames = np.asarray(e.frame_index, dtype=np.int64)
            for name, values, unit, what in (("rotation_deg", e.rotation_deg, 1.0, "deg"),
                                             ("translation_mm", e.translation_m, 1000.0,
                                              "mm")):
                ent = f"pose_error/{name}/{cam}"
                self.present.add("pose_error")
                self.rec.log(ent, rr.SeriesLines(names=f"{cam} ({e.source}) [{what}]",
                                                 colors=CAMERA_COLORS.get(cam, (200, 200, 200))),
                             static=True)
                self.rec.send_columns(ent, indexes=[rr.TimeColumn("frame", sequence=frames)],
                                      columns=rr.Scalars.columns(
                                          scalars=np.asarray(values, dtype=np.float64) * unit))


def log_convergence(rec, solvers, rr=None) -> None:
    """Error and predicted 1-sigma against the number of motions used (k), one
    named series per solver, on the ``motions`` timeline: ``convergence/rotation_deg/
    <solver>/{error,sigma}`` and ``convergence/translation_cm/<solver>/{error,sigma}``
    (from ``SolverResult.convergence``; failed or undetermined points are left out).
    ``rr``: the rerun module (or the recorder's stand-in for it)."""
    if rr is None:
        import rerun as rr
    for n, s in enumerate(solvers):
        pts = [p for p in getattr(s, "convergence", ()) if p.get("success")]
        if not pts:
            continue
        color = SOLVER_COLORS[n % len(SOLVER_COLORS)]
        k = np.array([p["k"] for p in pts], dtype=np.int64)
        for quantity, key, unit in (("rotation_deg", "rotation", 1.0),
                                    ("translation_cm", "translation", 100.0)):
            err = np.array([p[f"{key}_error_{'deg' if unit == 1.0 else 'm'}"] for p in pts],
                           dtype=np.float64) * unit
            sig = np.array([np.nan if p[f"sigma_{key}_{'deg' if unit == 1.0 else 'm'}"] is None
                            else p[f"sigma_{key}_{'deg' if unit == 1.0 else 'm'}"]
                            for p in pts], dtype=np.float64) * unit
            for part, vals, width in (("error", err, 2.0), ("sigma", sig, 1.0)):
                keep = np.isfinite(vals)
                if not keep.any():
                    continue
                ent = f"convergence/{quantity}/{entity_name(s.label)}/{part}"
                rec.log(ent, rr.SeriesLines(names=f"{s.label} {part}", colors=color,
                                            widths=width), static=True)
                rec.send_columns(ent, indexes=[rr.TimeColumn("motions", sequence=k[keep])],
                                 columns=rr.Scalars.columns(scalars=vals[keep]))
