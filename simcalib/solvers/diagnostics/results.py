"""The results of the uncertainty model: :class:`Direction` (one direction of the error
space and its state) and :class:`Uncertainty` (covariance, verdict, directions)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.solvers.diagnostics.inputs import (
    NoiseModel,
    _check_X,
    _real,
    pose_error,
)


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class Direction:
    """An eigen-direction of the (tolerance-scaled) information the data do not pin down.

    ``reason``: "undetermined" or "poorly determined"; ``rotation_axis_a`` /
    ``translation_dir_a``: unit 3-vectors in camera-a coordinates (zeros if that part is
    < 5 % of the direction); ``std_deg`` / ``std_m``: 1-sigma of the rotation / translation
    part along it from the data alone (inf when undetermined); ``std_with_prior_deg/_m``:
    the same with the prior; ``determined_by_prior``: the prior brings it within tolerance;
    ``description``: words.
    """
    reason: str
    kind: str
    rotation_axis_a: np.ndarray
    translation_dir_a: np.ndarray
    std_deg: float
    std_m: float
    std_with_prior_deg: float
    std_with_prior_m: float
    determined_by_prior: bool
    description: str

    with_prior: bool = False   # a prior was given (``std_with_prior_*`` are its sigma)

    @property
    def state(self) -> str:
        """``fixed by the prior``, ``poorly determined``, ``undetermined`` (see
        :func:`direction_state`)."""
        return direction_state(self.reason, self.determined_by_prior, self.with_prior,
                               math.isfinite(self.std_with_prior_deg)
                               and math.isfinite(self.std_with_prior_m))

    def sigma_text(self) -> str:
        """The 1-sigma that applies to this direction, in words: with the prior when one
        was given, else from the motions alone."""
        if self.with_prior:
            return direction_sigma(self.kind, self.std_with_prior_deg,
                                   self.std_with_prior_m, with_prior=True)
        return direction_sigma(self.kind, self.std_deg, self.std_m)

    def summary(self) -> str:
        """``<description>: <state> (<sigma>)``: the one rendering of a direction (console
        footnotes, results.json words, Solution.message)."""
        return f"{self.description}: {self.state} ({self.sigma_text()})"


#: the states a direction of X can be in, best first
DIRECTION_STATES = ("determined", "fixed by the prior", "poorly determined",
                    "poorly determined (prior only)", "undetermined")


def direction_state(reason: str, determined_by_prior: bool, with_prior: bool = False,
                    prior_sigma_finite: bool = False) -> str:
    """The state of a flagged direction, in the words every report uses: ``fixed by the
    prior`` (the prior brings it within tolerance), ``poorly determined (prior only)`` (the
    motions do not determine it, the prior bounds it but not within tolerance), else the
    motions' ``reason`` (``poorly determined`` / ``undetermined``)."""
    if determined_by_prior:
        return "fixed by the prior"
    if reason == "undetermined" and with_prior and prior_sigma_finite:
        return "poorly determined (prior only)"
    return reason


def direction_sigma(kind: str, std_deg: float, std_m: float, with_prior: bool = False
                    ) -> str:
    """``1-sigma 2.3 cm`` for a translation direction, ``1-sigma 0.5 deg`` for a rotation,
    both for a coupled one (only the parts that apply); ``no finite 1-sigma: ...`` when it
    is infinite."""
    parts = [(std_deg, "deg")] if kind in ("rotation", "coupled") else []
    parts += [(std_m, "m")] if kind in ("translation", "coupled") else []
    if not all(math.isfinite(x) for x, _ in parts):
        return ("no finite 1-sigma: neither the motions nor the prior constrain it"
                if with_prior else "no finite 1-sigma: the motions do not constrain it")
    return ("1-sigma " + ", ".join(_fmt_std(x, unit) for x, unit in parts)
            + (" with the prior" if with_prior else ""))


def _fmt_std(x, unit):
    if unit == "m" and math.isfinite(x) and x < 1.0:
        return f"{100 * x:.3g} cm"
    return "inf " + unit if not math.isfinite(x) else f"{x:.3g} {unit}"


def _fmt_vec(v) -> str:
    return "[" + ", ".join(f"{x:+.3f}" for x in v) + "]"


@dataclass(frozen=True, eq=False)
class Uncertainty:
    """Uncertainty of estimate ``X`` (see module doc). Arrays are 6x6 in the order
    ``(wx, wy, wz, vx, vy, vz)``, rad and m, frame a."""
    X: np.ndarray
    covariance: np.ndarray
    covariance_determined: np.ndarray
    determined_basis: np.ndarray
    information: np.ndarray
    prior_covariance: np.ndarray | None
    noise: NoiseModel
    alpha: float
    tolerance_deg: float
    tolerance_m: float
    directions: tuple
    translation_scale_m: float
    n_motions: int
    method: str = "sandwich"
    offset: np.ndarray | None = None   # Gauss-Newton step from X to the alpha-cost minimiser
    bias_covariance: np.ndarray | None = None   # part of covariance from pose_bias (6x6)
    # the noise-only information (verdict null, 6x6 like ``information``), the generalised
    # eigenvalues of (information, noise_information) ascending, and their thresholds
    noise_information: np.ndarray | None = None
    information_ratio: np.ndarray | None = None
    ratio_threshold: np.ndarray | None = None
    # motions from pose streams (``pose_pairs``): the white pose-noise test and, when it
    # passed, the simulated bias of the alpha-cost minimiser (delta coordinates, estimate
    # minus truth; its outer product is part of ``covariance``)
    pose_noise_test: object = None
    simulated_bias: np.ndarray | None = None
    # with ``pose_error_basis``: the number of systematic parameters the simulation drew
    # (0: none) and the white pose noise it added beyond them (per pose: rad, m)
    systematic_parameters: int = 0
    white_pose_noise: tuple | None = None
    # the simulation itself (pose_noise.SimulatedError), to reuse for other estimates of
    # the same motions (``covariance(..., pose_simulation=...)``)
    simulation: object = None

    @property
    def std(self) -> np.ndarray:
        """1-sigma per axis: (wx, wy, wz) in deg, (vx, vy, vz) in m (inf if undetermined)."""
        s = np.sqrt(np.diag(self.covariance))
        return np.concatenate([np.degrees(s[:3]), s[3:]])

    @property
    def simulated_bias_determined(self) -> np.ndarray | None:
        """``simulated_bias`` with NaN along the undetermined axes (a bias along a direction
        the data cannot determine means nothing); None without a simulation."""
        if self.simulated_bias is None:
            return None
        return np.where(np.isfinite(np.diag(self.covariance)), self.simulated_bias, np.nan)

    @property
    def std_deg(self) -> np.ndarray:
        return self.std[:3]

    @property
    def std_m(self) -> np.ndarray:
        return self.std[3:]

    @property
    def undetermined(self) -> tuple:
        return tuple(d for d in self.directions if d.reason == "undetermined")

    @property
    def poorly_determined(self) -> tuple:
        return tuple(d for d in self.directions if d.reason == "poorly determined")

    @property
    def degenerate(self) -> bool:
        """True when the motions leave any direction undetermined or poorly determined
        (even if a prior fixes it; see ``Direction.determined_by_prior``)."""
        return bool(self.directions)

    @property
    def verdict(self) -> str:
        if not self.directions:
            return "determined"
        if self.undetermined:
            return "undetermined"
        return "poorly determined"

    def summary(self) -> str:
        s = self.std
        head = (f"1-sigma rot {_fmt_vec3(s[:3])} deg, trans {_fmt_vec3(s[3:])} m "
                f"(noise {'estimated' if self.noise.estimated else 'given'}: "
                f"{math.degrees(self.noise.sigma_r_rad):.3g} deg, {self.noise.sigma_t_m:.3g} m)")
        if not self.directions:
            return (f"determined within {self.tolerance_deg:g} deg / {self.tolerance_m:g} m; "
                    + head)
        return (f"the motions leave X {self.verdict}: "
                + "; ".join(d.summary() for d in self.directions) + "; " + head)

    def mahalanobis2(self, X_candidate) -> float:
        """``d^T Sigma_det^+ d`` with ``d`` the error of ``X_candidate`` relative to ``X``,
        over the determined directions only."""
        d = pose_error(_check_X(X_candidate, "X_candidate"), self.X)
        B = self.determined_basis
        if B.shape[1] == 0:
            return 0.0
        c = B.T @ d
        S = B.T @ self.covariance_determined @ B
        return float(c @ np.linalg.lstsq(S, c, rcond=None)[0])

    @property
    def dof(self) -> int:
        return int(self.determined_basis.shape[1])

    def inside_region(self, X_candidate, level: float = 0.95) -> bool:
        """True if ``X_candidate`` lies in the ``level`` confidence region of ``X``: its
        squared Mahalanobis distance over the ``k`` determined directions is at most the
        chi-square(k) quantile. Undetermined directions are unconstrained."""
        level = _real("level", level)
        if not level < 1:
            raise ValueError(f"level must be in (0, 1); received {level}")
        if self.dof == 0:
            return True
        from scipy.special import chdtri
        return self.mahalanobis2(X_candidate) <= chdtri(self.dof, 1.0 - level)


def _fmt_vec3(v):
    return "[" + ", ".join("inf" if not math.isfinite(x) else f"{x:.3g}" for x in v) + "]"


