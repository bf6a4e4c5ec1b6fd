"""An error common to every pose of a stream: stated by the user, since no data can show it.

A robot's absolute accuracy (the flange pose it reports against the true one), a tracker's
or a target's calibration: where such an error is the same at every pose and lies in the
sensor's own frame (``T_wa_a E``), every motion becomes ``E^-1 C E`` and the calibration
returns exactly ``E^-1 X`` - X moves and no residual shows it (the generated robot_error
recordings: ``docs/calibrate-coverage.md``). An error in the world frame (``E T_wa_a``)
cancels in the motions and moves nothing. So the reported sigma holds what the data
determine (``uncertainty.not_included`` says so) unless the user states that error:
:class:`CommonError` gives its covariance in X's ``pose_error`` coordinates, which the
estimation path adds to the determined directions.

To first order (``E = exp(eps)`` on a's poses and ``F = exp(phi)`` on b's, right-multiplied)
X becomes ``E^-1 X F``: the map of
:func:`simcalib.solvers.diagnostics.inputs.pose_bias_jacobians`, the same one that carries a
simulated camera's calibration error (``PoseBias``) into the covariance of ``run``. Each
error is isotropic: its rotation angle and translation length have the stated rms, i.e.
``rms / sqrt(3)`` per axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from simcalib.config.engine import key_help

__all__ = ["CommonError"]


@dataclass(frozen=True)
class CommonError:
    """``common_error.*`` of ``calibrate``: the rms of an error common to every pose of
    stream a and of stream b, in each sensor's own frame (rotation angle, translation
    length); 0: not stated."""
    rotation_a_deg: float = field(default=0.0, metadata=key_help(
        "rms rotation of an error common to every pose of a, in a's frame (a robot's "
        "absolute accuracy at the flange), degrees; added to sigma (no data can show it)"))
    translation_a_m: float = field(default=0.0, metadata=key_help(
        "rms translation of that error of a, metres"))
    rotation_b_deg: float = field(default=0.0, metadata=key_help(
        "rms rotation of an error common to every pose of b, in b's frame, degrees"))
    translation_b_m: float = field(default=0.0, metadata=key_help(
        "rms translation of that error of b, metres"))

    def __post_init__(self):
        from simcalib.config.checks import check_positive, set_fields
        set_fields(self, **{k: check_positive(k, v, allow_zero=True)
                            for k, v in self.to_dict().items()})

    @property
    def stated(self) -> bool:
        return any(v > 0 for v in self.to_dict().values())

    def covariance(self, X) -> np.ndarray:
        """``(6, 6)``: the covariance these errors give X (``pose_error`` coordinates:
        ``(wx, wy, wz, vx, vy, vz)``, rad and m, frame a)."""
        from simcalib.solvers.diagnostics.inputs import pose_bias_covariance
        return pose_bias_covariance(X, _isotropic(self.rotation_a_deg, self.translation_a_m),
                                    _isotropic(self.rotation_b_deg, self.translation_b_m))

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def _isotropic(rotation_deg: float, translation_m: float) -> np.ndarray:
    """``(6, 6)``: the covariance of an isotropic pose error whose rotation angle and
    translation length have the given rms (``rms**2 / 3`` per axis)."""
    return np.diag([math.radians(rotation_deg) ** 2 / 3.0] * 3 + [translation_m ** 2 / 3.0] * 3)
