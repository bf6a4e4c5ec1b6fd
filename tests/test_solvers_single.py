"""The plain single-problem solve (simcalib/solvers/single.py): every registered method on
pure-translation motions (a cart or a linear stage: no rotation), and the check that keeps
a method whose rotation step uses the motions' rotations alone from presenting a rotation
fitted to the noise as an estimate (:func:`simcalib.solvers.problem.rotation_shortfall`)."""

from __future__ import annotations

import numpy as np
import pytest

import simcalib
from simcalib.errors import SimcalibError
from simcalib.geometry import (invert_transform, matrix_from_rotvec, perturb_transforms,
                               rotation_error_rad, transform_from_rotation_translation)
from simcalib.solvers.problem import rotation_shortfall
from simcalib.solvers.registry import available, get

X_TRUE = transform_from_rotation_translation(matrix_from_rotvec([0.3, -0.5, 0.2]),
                                             [0.05, 0.02, 0.1])


def _translations(rng, n, shape, noise_deg, noise_m=0.001):
    d = rng.normal(size=(n, 3)) * 0.2
    if shape == "planar":
        d[:, 2] = 0.0
    H = transform_from_rotation_translation(np.broadcast_to(np.eye(3), (n, 3, 3)), d)
    C = X_TRUE @ H @ invert_transform(X_TRUE)
    if noise_deg or noise_m:
        C = perturb_transforms(C, np.radians(noise_deg), noise_m, rng)
        H = perturb_transforms(H, np.radians(noise_deg), noise_m, rng)
    return C, H


CASES = [(shape, n, noise) for shape in ("3d", "planar") for n in (5, 40)
         for noise in (0.0, 0.1, 0.5)]


@pytest.mark.parametrize("method", available())
def test_every_solver_solves_pure_translation_or_names_the_motion(method):
    """Each method either returns X's rotation (within 3x dqopt's error + 0.2 deg: the
    translations determine it) or reports the degenerate motion: success False with a
    message naming it, or a simcalib error. Never a numpy exception, never a wrong
    rotation presented as an estimate."""
    for k, (shape, n, noise) in enumerate(CASES):
        C, H = _translations(np.random.default_rng(k), n, shape, noise)
        ref = np.degrees(rotation_error_rad(simcalib.solve(C, H).X, X_TRUE))
        try:
            s = simcalib.solve(C, H, method=method)
        except SimcalibError as exc:
            assert "translation" in str(exc) or "rotat" in str(exc), (method, str(exc))
            continue
        msg = s.solver_message
        if not s.success or s.diagnostics.get("rotation_shortfall"):
            assert "degenerate" in msg or "rotat" in msg, (method, shape, n, noise, msg)
            assert s.degenerate, (method, "a rotation fitted to the noise is not an estimate")
            continue
        err = np.degrees(rotation_error_rad(s.X, X_TRUE))
        assert err <= 3.0 * ref + 0.2, (method, shape, n, noise, err, ref)
        assert s.uncertainty.degenerate, (method, "the translation is undetermined")


def test_rotation_step_methods_are_marked_and_flag_pure_translation():
    """Their answer stays (the paper's Table 2 measures it on ``line``), flagged: the
    message names the motion and the solution is degenerate."""
    C, H = _translations(np.random.default_rng(3), 40, "3d", 0.1)
    marked = [m for m in available() if get(m).extra.get("needs_rotation")]
    assert {"dq2steps", "daniilidis", "opencv_park", "opencv_horaud"} <= set(marked)
    for m in marked:
        s = simcalib.solve(C, H, method=m)
        assert "too few motions rotate beyond the pose noise" in s.solver_message, m
        assert "rotation of X is undetermined" in s.solver_message, m
        assert s.degenerate and s.diagnostics["rotation_shortfall"], m
    s = simcalib.solve(C, H, method="dqopt")            # the translations give its rotation
    assert "rotation_shortfall" not in s.diagnostics


def test_rotation_shortfall_tells_rotation_from_noise():
    rng = np.random.default_rng(0)
    C, H = _translations(rng, 200, "3d", 0.5)        # noise of 0.5 deg a pose: still none
    assert rotation_shortfall(C, H) is not None
    R = matrix_from_rotvec(rng.normal(size=(200, 3)) * 0.2)     # ~20 deg motions
    H2 = transform_from_rotation_translation(R, rng.normal(size=(200, 3)) * 0.1)
    C2 = X_TRUE @ H2 @ invert_transform(X_TRUE)
    assert rotation_shortfall(C2, H2) is None
    assert rotation_shortfall(perturb_transforms(C2, np.radians(0.1), 0.001, rng),
                              perturb_transforms(H2, np.radians(0.1), 0.001, rng)) is None
