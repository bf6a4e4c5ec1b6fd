"""Plausibility of a calibration's answer: what the poses can say beyond the fit.

Every reading of two pose files has a twin that fits exactly as well: inverting *both*
streams turns ``C X = X H`` into the same equations for ``X' = T_wa_wb`` (the pose of
world b in world a), because ``T_wa_a X T_b_wb`` is constant along a rigid pair. The fit
cannot choose between the two; their sizes can. A sensor pair is usually mounted within
decimetres, while two worlds (a robot base and a target, two odometry origins) are often
metres apart; an answer whose translation is many times the twin's is therefore most likely
the twin — the classic sign of a file that holds the inverse poses (``T_tool_base`` for
``T_base_tool``). It stays a warning (exit 6), never a silent switch: a rig whose sensors
really are far apart (a tag on a robot seen by a far camera) has exactly that shape.

When the caller chose the reading (forced ``invert_a`` / ``invert_b``) or declared a camera
on the robot base (``eye="on_base"``: X is the camera's pose in the base, metres long by
nature), the long answer is the one asked for: the twin is kept as a note, never a flag.
With ``eye="on_base"`` and the reading left to the data, the check reads the declared
shape the other way round: an X many times shorter than its twin is the marker on the
flange (``T_ee_marker``), not the camera in the base the caller asked for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcalib.geometry import chordal_mean_rotation, invert_transform

__all__ = ["Plausibility", "check_plausibility", "chosen_by", "TWIN_RATIO", "TWIN_MARGIN_M"]

#: An answer is flagged when its translation is at least this many times the twin's ...
TWIN_RATIO = 3.0
#: ... and longer than the twin's by at least this much (metres): a few centimetres on
#: both sides say nothing.
TWIN_MARGIN_M = 0.25


@dataclass(frozen=True)
class Plausibility:
    """``translation_m``: |t| of X; ``twin_translation_m``: |t| of the both-inverted
    reading's answer ``T_wa_wb`` (``twin_X``: the chordal mean rotation and the mean
    translation of ``T_wa_a X T_b_wb`` over the synchronised poses); ``twin_hint``: the
    keys that would select the twin; ``warnings``: sentences for people (empty: nothing
    implausible)."""
    translation_m: float
    twin_translation_m: float
    twin_hint: str
    warnings: tuple = ()
    #: the twin's answer ``T_wa_wb`` (4, 4): X if both files hold the inverse poses
    twin_X: np.ndarray | None = None
    #: what made the long answer expected (the forced keys, ``eye=on_base``); "" if nothing
    chosen_by: str = ""
    #: sentences for people that flag nothing (the twin the caller did not ask for)
    notes: tuple = ()

    @property
    def plausible(self) -> bool:
        return not self.warnings

    def to_dict(self) -> dict:
        return {"translation_m": self.translation_m,
                "twin_translation_m": self.twin_translation_m,
                "twin_T_a_b": None if self.twin_X is None else self.twin_X.tolist(),
                "twin_hint": self.twin_hint, "plausible": self.plausible,
                "reading_chosen_by": self.chosen_by or None,
                "warnings": list(self.warnings), "notes": list(self.notes)}


def chosen_by(conventions, eye: str | None = None) -> str:
    """What of the caller's makes X the answer asked for whatever its length: the forced
    inversions (``conventions.forced``: the absolute reading is then the caller's, the
    twin is not) and ``eye="on_base"`` (X is the camera's pose in the robot base); ""
    when neither."""
    keys = [k for k in getattr(conventions, "forced", ()) if k in ("invert_a", "invert_b")]
    if eye == "on_base":
        keys.append("eye=on_base")
    return ", ".join(keys)


def check_plausibility(X, T_wa_a, T_wb_b, conventions, eye: str | None = None,
                       translation_undetermined: bool = False) -> Plausibility:
    """The :class:`Plausibility` of ``X = T_a_b`` estimated from the synchronised poses
    ``T_wa_a``, ``T_wb_b`` (``(N, 4, 4)``, in the reading used), the reading chosen
    (``conventions``: :class:`simcalib.estimation.readings.ConventionReport`) and the
    caller's ``eye`` (``in_hand``, ``on_base`` or None).

    Flagged (a warning): the unforced reading gives an X at least :data:`TWIN_RATIO` times
    and :data:`TWIN_MARGIN_M` longer than its twin's (with ``eye="on_base"``: shorter).
    A caller who forced invert_a / invert_b asked for this reading: the same shape is
    only a note. ``translation_undetermined`` (no axis of X's translation has a finite
    sigma: a rig that only translates): the lengths say nothing, nothing is flagged (a
    note says so)."""
    X = np.asarray(X, dtype=np.float64)
    T_wa_a, T_wb_b = np.asarray(T_wa_a, np.float64), np.asarray(T_wb_b, np.float64)
    if X.shape != (4, 4) or T_wa_a.ndim != 3 or T_wa_a.shape != T_wb_b.shape:
        raise ValueError(f"check_plausibility needs X (4, 4) and two (N, 4, 4) pose arrays "
                         f"of one shape; received {X.shape}, {T_wa_a.shape}, {T_wb_b.shape}")
    T_wa_wb = T_wa_a @ X @ invert_transform(T_wb_b)
    twin = np.eye(4)
    twin[:3, :3] = chordal_mean_rotation(T_wa_wb[:, :3, :3])
    twin[:3, 3] = T_wa_wb[:, :3, 3].mean(axis=0)
    t = float(np.linalg.norm(X[:3, 3]))
    t_twin = float(np.linalg.norm(twin[:3, 3]))
    hint = (f"invert_a={str(not conventions.invert_a).lower()} "
            f"invert_b={str(not conventions.invert_b).lower()}")
    chosen = chosen_by(conventions, eye)
    forced = any(k in getattr(conventions, "forced", ()) for k in ("invert_a", "invert_b"))
    long_x = _longer(t, t_twin)
    warnings, notes = (), ()
    if translation_undetermined:
        notes = ("X's translation is undetermined on every axis (the motions do not turn), "
                 "so its length and its twin's say nothing about the reading",)
    elif long_x and chosen:
        notes = (f"X's translation ({t:.3g} m) is {t / max(t_twin, 1e-12):.3g}x the twin's "
                 f"({t_twin:.3g} m, both streams inverted, printed below): expected, as the "
                 f"reading is the caller's ({chosen}); the twin is the other answer (the "
                 "pose of world b in world a), not the one asked for",)
    elif long_x:
        warnings = (f"X's translation ({t:.3g} m) is {t / max(t_twin, 1e-12):.3g}x the one "
                    f"the reading with both streams inverted gives ({t_twin:.3g} m), and "
                    "both readings fit the poses exactly alike: if sensor b sits closer "
                    "to a than that, the files hold the inverse poses (T_sensor_world) - "
                    f"rerun with {hint}",)
    elif eye == "on_base" and not forced and _longer(t_twin, t):
        warnings = (f"eye=on_base, but the twin's translation ({t_twin:.3g} m, both streams "
                    f"inverted, printed below) is {t_twin / max(t, 1e-12):.3g}x X's "
                    f"({t:.3g} m): X looks like the marker on the flange (T_ee_marker), not the "
                    "camera in the robot base; for T_base_camera give stream a as "
                    f"T_ee_base (a=/tf:EFFECTOR->BASE) or rerun with {hint}",)
    return Plausibility(t, t_twin, hint, warnings, twin, chosen, notes)


def _longer(t: float, t_other: float) -> bool:
    """``t`` is at least :data:`TWIN_RATIO` times and :data:`TWIN_MARGIN_M` longer."""
    return t >= TWIN_RATIO * t_other and t - t_other >= TWIN_MARGIN_M
