"""The verdict on an estimate, from ONE covariance: the reported one
(:mod:`simcalib.estimation.consistency`: from the poses' own errors, white and correlated,
checked by the recording's two halves; with a prior, the model's raised to a block
jackknife).

The solver's :class:`~simcalib.solvers.diagnostics.uncertainty.Uncertainty` names the
directions the motions leave undetermined or poorly determined. Where the reported
covariance exceeds the tolerance along other directions, they are added as "poorly
determined" with the reason. When the data are too few to check themselves, the verdict
says so (``unverified``) instead of presenting the sigma as checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from simcalib.config.engine import key_help

__all__ = ["Verdict", "judge", "Tolerances"]


@dataclass(frozen=True)
class Tolerances:
    """``verdict.*`` of ``calibrate``: a direction of X whose 1-sigma exceeds a tolerance is
    "poorly determined" (the same meaning as a scenario's ``verdict.tolerance_*``)."""
    tolerance_deg: float = field(default=1.0, metadata=key_help(
        "1-sigma rotation tolerance, degrees (above it: poorly determined)"))
    tolerance_m: float = field(default=0.01, metadata=key_help(
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


def _consistency_directions(cov_det, B, tol_r, tol_m, flagged) -> list:
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
        why = (" by the reported sigma (the poses' own errors, correlated ones included, and "
               "the data's consistency checks)")
        out.append(replace(d, description=d.description + why))
    return out


def _noise_determined(U, unc, flagged) -> list:
    """The directions ``U`` (6, u; delta coordinates) the pose errors alone determine, as
    undetermined :class:`Direction` s (those the model flags already left out)."""
    from simcalib.solvers.diagnostics.uncertainty import _describe
    if U is None or U.shape[1] == 0:
        return []
    dsc = np.array([math.radians(unc.tolerance_deg)] * 3 + [unc.tolerance_m] * 3)
    out = []
    for u in np.asarray(U).T:
        v = u / dsc
        d = _describe(v / np.linalg.norm(v), dsc, "undetermined", math.inf, math.inf,
                      math.inf, math.inf, False)
        seen = [np.concatenate([f.rotation_axis_a, f.translation_dir_a]) for f in flagged]
        if any(abs(float(np.dot(x, np.concatenate([d.rotation_axis_a, d.translation_dir_a]))))
               > 0.9 * np.linalg.norm(x) for x in seen if np.linalg.norm(x) > 0):
            continue
        out.append(replace(d, description=d.description + " (determined only by the pose "
                           "errors themselves: errors in the variables)"))
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
    from simcalib.estimation.consistency import PoseConsistency
    own = isinstance(consistency, PoseConsistency) and consistency.covariance is not None
    # with the poses' own covariance, how well a direction is determined is its reported
    # sigma; the model keeps its word on what the motions cannot determine at all
    dirs = [d for d in unc.directions if not own or d.reason == "undetermined"]
    if own:
        dirs += _noise_determined(consistency.undetermined, unc, dirs)
    notes = [] if consistency is None else list(consistency.notes())
    checked = consistency is not None and consistency.checked
    if weighting is not None and weighting.significant:
        notes.append(weighting.message)
    if consistency is not None or (weighting is not None and weighting.significant):
        basis = consistency.basis if own else None
        dirs += _consistency_directions(
            np.asarray(covariance_determined),
            np.asarray(unc.determined_basis if basis is None else basis),
            math.radians(unc.tolerance_deg), unc.tolerance_m, dirs)
    dirs.sort(key=lambda d: d.reason != "undetermined")
    if not dirs:
        v = "determined"
    elif any(d.reason == "undetermined" for d in dirs):
        v = "undetermined"
    else:
        v = "poorly determined"
    return Verdict(v, tuple(dirs), std_deg, std_m, not checked, tuple(notes))
