"""What every report says about how far an estimate can be trusted — ONE rendering of each
quantity, so that no two reports can disagree:

* a flagged direction of X: its state (:data:`DIRECTION_STATES`: determined, fixed by the
  prior, poorly determined, poorly determined (prior only), undetermined) and the 1-sigma
  that applies to it, in words (:func:`direction_record` stores both with the direction
  where it is computed; :func:`direction_words` renders them);
* a solver's sigma and its translation error with the flagged directions projected out,
  shown as :data:`NOT_MEASURED` with the reason when they are not numbers
  (:class:`SolverView`);
* a 1-sigma per axis (calibrate): :data:`NOT_MEASURED` for an axis with no finite one.

The console (:mod:`simcalib.report.console`), results.json (:mod:`simcalib.report.results`),
calibration.json and its console report (:mod:`simcalib.report.calibration`) and the
recordings' summary panes (:mod:`simcalib.report.rerun.run_summary`,
:mod:`simcalib.report.rerun.calibration`) all render from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["NOT_MEASURED", "REASON_ALL_PROJECTED", "REASON_SIGMA_INFINITE",
           "REASON_AXIS_INFINITE", "direction_record", "direction_state_of",
           "direction_sigma_of", "direction_words", "direction_tag", "SolverView",
           "solver_view", "determined_translation", "sigma_reason", "fmt_number",
           "pm_cell", "determined_cell", "axis_sigmas", "not_measured_notes"]

#: what every report shows for a number that is not a measurement (with a footnote)
NOT_MEASURED = "—"
#: the reasons, in the words of the footnotes and of results.json / calibration.json
REASON_ALL_PROJECTED = ("every translation direction is undetermined or poorly determined "
                        "and was projected out: no translation error is left to measure")
REASON_SIGMA_INFINITE = ("a direction of X is undetermined: its 1-sigma is infinite "
                         "(no finite uncertainty to report)")
REASON_AXIS_INFINITE = ("the data leave this axis undetermined: it has no finite 1-sigma "
                        "(no uncertainty to report)")


# ------------------------------------------------------------------------ directions
def direction_record(d) -> dict:
    """The record of a flagged :class:`simcalib.solvers.diagnostics.results.Direction`
    that results.json and calibration.json store and every report renders: its geometry,
    the motions' and the prior's 1-sigma, and — decided once, here, by the Direction's own
    rule — its ``state`` and ``sigma`` (the 1-sigma that applies, in words)."""
    return {"kind": d.kind, "reason": d.reason, "description": d.description,
            "rotation_axis_a": np.asarray(d.rotation_axis_a, float).tolist(),
            "translation_dir_a": np.asarray(d.translation_dir_a, float).tolist(),
            "std_deg": float(d.std_deg), "std_m": float(d.std_m),
            "determined_by_prior": bool(d.determined_by_prior),
            "with_prior": bool(getattr(d, "with_prior", False)),
            "state": d.state, "sigma": d.sigma_text()}


def _finite_along(cov, d: dict) -> bool:
    """True when ``cov`` (6x6, inf on undetermined axes) is finite on every axis that
    direction ``d`` has a part along (rotation axis, translation direction; > 5 %)."""
    if cov is None:
        return False
    part = np.concatenate([np.abs(d.get("rotation_axis_a", np.zeros(3))),
                           np.abs(d.get("translation_dir_a", np.zeros(3)))])
    var = np.diag(np.asarray(cov, dtype=np.float64))
    return bool(np.isfinite(var[part > 0.05]).all())


def direction_state_of(s, d: dict) -> str:
    """The state of flagged direction ``d`` (a :func:`direction_record`) of solver result
    ``s``: the one stored with it; for a record without one, the same rule
    (:func:`simcalib.solvers.diagnostics.results.direction_state`) on what it holds —
    with a prior, a direction the motions leave undetermined is bounded by the prior when
    the covariance is finite on the axes it touches."""
    if d.get("state"):
        return str(d["state"])
    from simcalib.solvers.diagnostics.results import direction_state
    with_prior = getattr(s, "prior", None) is not None
    return direction_state(d["reason"], bool(d.get("determined_by_prior")), with_prior,
                           with_prior and _finite_along(getattr(s, "covariance", None), d))


def direction_sigma_of(s, d: dict) -> str:
    """The 1-sigma that applies to direction ``d`` of ``s``, in words: the one stored with
    it; for a record without one, from the motions alone, or with a prior from the
    reported covariance along the direction."""
    if d.get("sigma"):
        return str(d["sigma"])
    from simcalib.solvers.diagnostics.results import direction_sigma
    cov = getattr(s, "covariance", None)
    if getattr(s, "prior", None) is not None and _finite_along(cov, d):
        C = np.asarray(cov, dtype=np.float64)

        def along(key, block):   # the variance along the direction's part (> 5 % entries)
            v = np.asarray(d.get(key, np.zeros(3)), dtype=np.float64)
            k = np.flatnonzero(np.abs(v) > 0.05)
            return math.sqrt(max(float(v[k] @ block[np.ix_(k, k)] @ v[k]), 0.0))
        return direction_sigma(d["kind"], math.degrees(along("rotation_axis_a", C[:3, :3])),
                               along("translation_dir_a", C[3:, 3:]), with_prior=True)
    return direction_sigma(d["kind"], float(d["std_deg"]), float(d["std_m"]))


def direction_words(s, d: dict) -> str:
    """``<description>: <state> (<sigma>)`` — the one sentence of a direction."""
    return f"{d['description']}: {direction_state_of(s, d)} ({direction_sigma_of(s, d)})"


def direction_tag(d: dict) -> str:
    """A short name: ``translation y``, ``rotation``, ``rot+trans x`` ..."""
    word = d["kind"] if d["kind"] != "coupled" else "rot+trans"
    ax = d["translation_dir_a"] if d["kind"] == "translation" else d["rotation_axis_a"]
    i = int(np.argmax(np.abs(ax)))
    return f"{word} {'xyz'[i]}" if abs(ax[i]) > 0.9 else word


# ------------------------------------------------------------------------ a solver
def determined_translation(s) -> tuple[float | None, str | None]:
    """``(translation_error_determined_m, None)``, or ``(None, reason)`` when every
    translation direction was projected out (what is left is rounding, ~1e-15 m: not a
    measurement)."""
    axes = getattr(s, "undetermined_translation_axes", None)
    if s.translation_error_determined_m is None or axes is None:
        return s.translation_error_determined_m, None
    axes = np.atleast_2d(np.asarray(axes, dtype=np.float64))
    if axes.size and np.linalg.matrix_rank(axes, tol=1e-6) >= 3:
        return None, REASON_ALL_PROJECTED
    return s.translation_error_determined_m, None


def sigma_reason(sigma) -> str | None:
    """Why a solver's sigma is not a number (infinite), else None."""
    if sigma is not None and not math.isfinite(sigma):
        return REASON_SIGMA_INFINITE
    return None


@dataclass(frozen=True)
class SolverView:
    """What every report says of one solver result: ``failed`` (the reason, or None),
    ``verdict`` (the motions' word), ``directions`` (records, each with ``state``,
    ``sigma``, ``tag``, ``words``), the sigmas and the determined error with the reasons
    they are :data:`NOT_MEASURED` (None: a number)."""
    label: str
    failed: str | None
    verdict: str
    directions: tuple
    sigma_rotation_deg: float | None
    sigma_rotation_reason: str | None
    sigma_translation_m: float | None
    sigma_translation_reason: str | None
    determined_m: float | None
    determined_reason: str | None
    unknown_reason: str | None = None   # verdict "unknown": why (no uncertainty)

    def verdict_cell(self, max_tags: int = 3) -> str:
        """The flagged directions grouped by state (worst first), at most ``max_tags``
        tags, the rest counted: ``undetermined: translation y; fixed by the prior: ...``."""
        from simcalib.solvers.diagnostics.results import DIRECTION_STATES
        if self.verdict in ("determined", "unknown", "FAILED") or not self.directions:
            return self.verdict
        by_state: dict[str, list[str]] = {}
        for d in self.directions:
            tags = by_state.setdefault(d["state"], [])
            if d["tag"] not in tags:
                tags.append(d["tag"])
        order = sorted(by_state, key=lambda st: -DIRECTION_STATES.index(st)
                       if st in DIRECTION_STATES else 1)
        parts, shown = [], 0
        for st in order:
            tags = by_state[st][:max(0, max_tags - shown)]
            shown += len(tags)
            if tags:
                parts.append(f"{st}: {', '.join(tags)}")
        hidden = sum(len(t) for t in by_state.values()) - shown
        return "; ".join(parts) + (f", +{hidden}" if hidden else "")


def solver_view(s) -> SolverView:
    """The :class:`SolverView` of a run's solver result (``SolverResult`` or a stand-in)."""
    if s.X is None:
        return SolverView(s.label, s.error or "no estimate", "FAILED", (), None, None,
                          None, None, None, None)
    dirs = tuple(dict(d) | {"state": direction_state_of(s, d),
                            "sigma": direction_sigma_of(s, d), "tag": direction_tag(d),
                            "words": direction_words(s, d)}
                 for d in (getattr(s, "undetermined_directions", None) or ()))
    det, det_reason = determined_translation(s)
    sr, st = getattr(s, "sigma_rotation_deg", None), getattr(s, "sigma_translation_m", None)
    verdict = getattr(s, "verdict", "unknown")
    unknown = ("; ".join(getattr(s, "undetermined", ()) or ()) or "no uncertainty") \
        if verdict == "unknown" else None
    return SolverView(s.label, None, verdict, dirs, None if sigma_reason(sr) else sr,
                      sigma_reason(sr), None if sigma_reason(st) else st, sigma_reason(st),
                      det, det_reason, unknown)


# ------------------------------------------------------------------------ numbers
def fmt_number(v, scale=1.0, digits=3) -> str:
    """A number for people (``-`` when absent, exponent notation when tiny or huge)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    v = v * scale
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 10 ** -digits):
        return f"{v:.2e}"
    return f"{v:.{digits}f}"


def pm_cell(err, sigma, reason, scale, digits) -> str:
    """``error ± sigma``; sigma :data:`NOT_MEASURED` when it has a ``reason``."""
    e = fmt_number(err, scale, digits)
    if reason:
        return f"{e} ± {NOT_MEASURED}"
    return e if sigma is None else f"{e} ± {fmt_number(sigma, scale, digits)}"


def determined_cell(view: SolverView) -> str:
    return NOT_MEASURED if view.determined_reason else fmt_number(view.determined_m, 100, 2)


def not_measured_notes(views) -> list[str]:
    """One footnote per reason a number of a solver table is :data:`NOT_MEASURED`."""
    ok = [v for v in views if v.failed is None]
    notes = []
    projected = [v.label for v in ok if v.determined_reason]
    if projected:
        notes.append(f"{NOT_MEASURED} in 'determined [cm]' [{', '.join(projected)}]: "
                     f"{REASON_ALL_PROJECTED}")
    infinite = [v.label for v in ok if v.sigma_rotation_reason or v.sigma_translation_reason]
    if infinite:
        notes.append(f"{NOT_MEASURED} as σ [{', '.join(infinite)}]: {REASON_SIGMA_INFINITE}")
    return notes


def axis_sigmas(values, scale: float = 1.0, digits: int = 3) -> list[str]:
    """A 1-sigma per axis as text: :data:`NOT_MEASURED` where it is absent or infinite
    (:data:`REASON_AXIS_INFINITE`)."""
    return [NOT_MEASURED if x is None or not math.isfinite(x) else f"{scale * x:.{digits}f}"
            for x in values]
