"""The verdict on an estimate, from ONE covariance: the model's, raised where the data are
less consistent than the model says (:mod:`simcalib.estimation.consistency`).

The solver's :class:`~simcalib.solvers.diagnostics.uncertainty.Uncertainty` names the
directions the motions leave undetermined or poorly determined. With the reported
covariance larger than the model's, more directions can exceed the tolerance: they are
added as "poorly determined" with the reason (the data's own consistency). When the data
are too few to check themselves, the verdict says so (``unverified``) instead of presenting
the model's sigma as checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["Verdict", "judge", "Tolerances"]


def _doc(text: str) -> dict:
    return {"help": text}


@dataclass(frozen=True)
class Tolerances:
    """``verdict.*`` of ``calibrate``: a direction of X whose 1-sigma exceeds a tolerance is
    "poorly determined" (the same meaning as a scenario's ``verdict.tolerance_*``)."""
    tolerance_deg: float = field(default=1.0, metadata=_doc(
        "1-sigma rotation tolerance, degrees (above it: poorly determined)"))
    tolerance_m: float = field(default=0.01, metadata=_doc(
        "1-sigma translation tolerance, metres (above it: poorly determined)"))

    def __post_init__(self):
        from simcalib.config.checks import check_positive, set_fields
        set_fields(self, tolerance_deg=check_positive("tolerance_deg", self.tolerance_deg),
                   tolerance_m=check_positive("tolerance_m", self.tolerance_m))


@dataclass(frozen=True)
class Verdict:
    """``verdict``: ``determined``, ``poorly determined``, ``undetermined`` or ``FAILED``;
    ``directions``: the flagged :class:`Direction`\\ s; ``std_deg`` / ``std_m``: 1-sigma
    per axis of the reported covariance (inf: undetermined); ``unverified``: the data could
    not check the model's sigma; ``notes``: sentences for people."""
    verdict: str
    directions: tuple
    std_deg: tuple
    std_m: tuple
    unverified: bool
    notes: tuple = ()

    @property
    def degenerate(self) -> bool:
        return self.verdict in ("undetermined", "poorly determined")

    def summary(self) -> str:
        """The flagged directions and the notes (the verdict word itself is not repeated:
        the caller prints it once)."""
        return "; ".join([d.summary() for d in self.directions] + list(self.notes))


def _consistency_directions(cov_det, B, tol_r, tol_m, flagged, ratio) -> list:
    """Directions of ``cov_det`` on the determined basis ``B`` beyond the tolerance that
    the model's own directions do not already flag."""
    from simcalib.solvers.diagnostics.uncertainty import _describe
    dsc = np.array([tol_r] * 3 + [tol_m] * 3)
    if B.shape[1] == 0:
        return []
    S = (B.T @ cov_det @ B)
    lam, V = np.linalg.eigh(0.5 * (S + S.T))
    out = []
    seen = [np.concatenate([d.rotation_axis_a, d.translation_dir_a]) for d in flagged]
    for k in range(lam.size):
        u_phys = B @ V[:, k]
        u = u_phys / dsc
        s_tol = math.sqrt(max(lam[k], 0.0))
        nw, nt = np.linalg.norm(u_phys[:3]), np.linalg.norm(u_phys[3:])
        sdeg, sm = math.degrees(s_tol * nw), s_tol * nt
        if not (sdeg > math.degrees(tol_r) or sm > tol_m):
            continue
        d = _describe(u / np.linalg.norm(u), dsc, "poorly determined", sdeg, sm, sdeg, sm,
                      False)
        if any(abs(float(np.dot(v, np.concatenate([d.rotation_axis_a, d.translation_dir_a]))))
               > 0.9 * np.linalg.norm(v) for v in seen if np.linalg.norm(v) > 0):
            continue
        why = " by the data's own consistency checks (block jackknife, weighting)"
        out.append(replace(d, description=d.description + why))
    return out


def judge(solution, covariance, covariance_determined, consistency,
          weighting=None) -> Verdict:
    """The :class:`Verdict` of ``solution`` (a :class:`simcalib.Solution`) with the
    reported ``covariance`` (6x6, inf on undetermined axes) and its finite part, and the
    ``consistency`` check (or None) and the ``weighting`` check (or None)."""
    unc = solution.uncertainty
    cov = np.asarray(covariance, dtype=np.float64)
    s = np.sqrt(np.diag(cov))
    std_deg = tuple(float(x) for x in np.degrees(s[:3]))
    std_m = tuple(float(x) for x in s[3:])
    dirs = list(unc.directions)
    notes = []
    checked = consistency is not None and consistency.checked
    if checked and consistency.raised:
        dirs += _consistency_directions(
            np.asarray(covariance_determined), np.asarray(unc.determined_basis),
            math.radians(unc.tolerance_deg), unc.tolerance_m, dirs, consistency.ratio)
        notes.append(f"sigma raised to the data's own consistency (block jackknife over "
                     f"{consistency.blocks} blocks of poses: its spread up to "
                     f"{math.sqrt(consistency.ratio):.3g}x the model's 1-sigma)")
    elif checked:
        notes.append(f"the model's sigma agrees with the data's own consistency (block "
                     f"jackknife over {consistency.blocks} blocks: its spread within chance)")
    elif consistency is not None:
        notes.append("UNVERIFIED: " + consistency.message)
    if weighting is not None and weighting.significant:
        notes.append(weighting.message)
        if not (checked and consistency.raised):
            dirs += _consistency_directions(
                np.asarray(covariance_determined), np.asarray(unc.determined_basis),
                math.radians(unc.tolerance_deg), unc.tolerance_m, dirs, 1.0)
    dirs.sort(key=lambda d: d.reason != "undetermined")
    if not dirs:
        v = "determined"
    elif any(d.reason == "undetermined" for d in dirs):
        v = "undetermined"
    else:
        v = "poorly determined"
    return Verdict(v, tuple(dirs), std_deg, std_m, not checked, tuple(notes))
