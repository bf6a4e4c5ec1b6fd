"""The kinds whose files must be read another way (what
:mod:`simcalib.estimation.readings` and the stamp units detect): b written inverted, a
quaternion written scalar first, stamps in ms / us / ns or since the Unix epoch, b's
translations in another scale.
"""

from __future__ import annotations

import math
from dataclasses import replace

from simcalib.studies.experiments.recording_models import (_continuous, _small_offset,
                                                           _stations_draft)

__all__ = ["UNIX_EPOCH_S"]


def _kind_inverted(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="inverted")
    return replace(d, invert_b=True, description=d.description + ", file b holds "
                   "T_cam_target (inverted)")


def _kind_scalar_first(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="scalar_first")
    which = "b" if rngs["seed"] % 2 == 0 else "a"       # seeds take turns
    return replace(d, scalar_first_a=which == "a", scalar_first_b=which == "b",
                   description=d.description + f", file {which} writes quaternions w first")


#: which file writes its stamps in which unit, relative to its first stamp ("unix ...":
#: since the Unix epoch, :data:`UNIX_EPOCH_S` before the recording's clock), by seed % 8
_STAMP_UNIT_CYCLE = (("ms", "s"), ("s", "ms"), ("ms", "ms"), ("us", "s"), ("s", "ns"),
                     ("us", "us"), ("unix s", "s"), ("s", "unix s"))
UNIX_EPOCH_S = 1.765e9


def _kind_stamp_units(rngs, s):
    """continuous, an offset of +-0.2 s (30..100 ppm drift in odd seeds), one or both files
    stamped relative to their first pose in ms, us or ns, or one since the Unix epoch
    (:data:`_STAMP_UNIT_CYCLE`)."""
    r = rngs["events"]
    off = float(r.uniform(-0.2, 0.2)) if s.offset_s is None else float(s.offset_s)
    drift_ppm = float(r.choice([-1.0, 1.0]) * r.uniform(30.0, 100.0))
    drift_ppm = (drift_ppm if rngs["seed"] % 2 else 0.0) if s.drift_ppm is None \
        else float(s.drift_ppm)
    d = _continuous(rngs, s, offset_s=off, drift=1e-6 * drift_ppm, label="stamp_units")
    ua, ub = _STAMP_UNIT_CYCLE[rngs["seed"] % len(_STAMP_UNIT_CYCLE)]
    # the origin subtracted: the file's first pose, 0 (seconds as they are) or the epoch
    sa, sb = (-UNIX_EPOCH_S if u.startswith("unix") else float(t[0]) if u != "s" else 0.0
              for u, t in ((ua, d.t_a), (ub, d.t_b)))
    how = f"stamps of a in {ua}, of b in {ub}"
    return replace(d, t_a=d.t_a - sa, t_b=d.t_b - sb, offset_s=d.offset_s - sb + sa,
                   t_ref_s=d.t_ref_s - sa, stamps_unit_a=ua.split()[-1],
                   stamps_unit_b=ub.split()[-1], description=d.description + f", {how}")


def _with_scale(rngs, d):
    """``d`` with b's translations times a scale drawn log-uniformly in [1.1, 3] (odd seeds)
    or [0.3, 1 / 1.1] (even seeds): clearly off 1, on both sides (a scale within a few %
    of 1 is what ``scale_b=auto`` keeps, docs/calibrate.md)."""
    r = rngs["events"]
    hi = math.log(3.0) if rngs["seed"] % 2 else math.log(1.0 / 0.3)
    sign = 1.0 if rngs["seed"] % 2 else -1.0
    scale = math.exp(sign * r.uniform(math.log(1.1), hi))
    B = d.B.copy()
    B[:, :3, 3] *= scale
    return replace(d, B=B, scale_b=scale, description=d.description
                   + f", b's translations x {scale:.4g} (unknown scale)")


def _kind_scale(rngs, s):
    return _with_scale(rngs, _continuous(rngs, s, offset_s=_small_offset(rngs, s),
                                         label="scale"))


def _kind_scale_stations(rngs, s):
    return _with_scale(rngs, _stations_draft(rngs, s, (10, 40), "scale_stations"))
