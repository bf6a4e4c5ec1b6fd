"""The verdict of every solution (issue 9): ``Solution.degenerate`` / ``undetermined`` /
``message`` follow from the uncertainty (simcalib.solvers.diagnostics.uncertainty), with the
directions in words (camera-a frame), their 1-sigma and whether a prior fixed them.
``Solution.observability`` stays as a description of the motion geometry."""

import numpy as np
import pytest

import simcalib
from simcalib import geometry as g
from simcalib.solvers import available
from simcalib.solvers.api import Prior
from solver_cases import general_case, motions_from_C, planar_case, random_X

FLAGGED = ("undetermined", "poorly determined")


def _translation_dirs(sol):
    return [d for d in sol.undetermined if d.kind == "translation"]


def test_general_motion_not_degenerate():
    rng = np.random.default_rng(21)
    for sigma in (0.0, 0.01):
        C, H, X = general_case(rng, n=30, sigma_r=sigma, sigma_t=sigma)
        sol = simcalib.solve(C, H)
        assert not sol.degenerate and sol.undetermined == () and sol.verdict == "determined"
        assert "determined within 1 deg / 0.01 m" in sol.message
        assert sol.message == sol.message  # cached, stable
        obs = sol.observability                       # descriptive geometry still there
        assert obs.singular_values.shape == (6,)
        assert np.all(np.diff(obs.singular_values) >= 0)


@pytest.mark.parametrize("method", available())
def test_planar_flagged_for_every_method(method):
    rng = np.random.default_rng(22)
    axis = np.array([0.2, 0.9, -0.4])
    C, H, X, k = planar_case(rng, n=25, axis=axis, sigma_r=1e-3, sigma_t=1e-3)
    sol = simcalib.solve(C, H, method=method, rng=np.random.default_rng(0))
    # a method may fail on degenerate input (it must then say why instead of raising)
    if not sol.success:
        assert sol.solver_message and "FAILED" in sol.message, method
        assert sol.degenerate and sol.verdict == "FAILED"
        return
    assert sol.degenerate, (method, sol.message)
    tr = _translation_dirs(sol)
    assert tr and all(d.reason in FLAGGED for d in tr), sol.message
    assert any(abs(d.translation_dir_a @ k) > 0.99 for d in tr)   # the common axis, frame a
    assert not any(d.determined_by_prior for d in sol.undetermined)
    assert "planar motion" in sol.observability.motion
    for d in tr:                                       # sigma in words, in the message
        assert d.description in sol.message and d.reason.upper() in sol.message.upper()


def test_planar_dq_solution_exact_except_along_axis():
    rng = np.random.default_rng(23)
    C, H, X, k = planar_case(rng, n=25, axis=[0.0, 0.0, 1.0])
    sol = simcalib.solve(C, H)
    assert g.rotation_error_rad(sol.X, X) < 1e-9      # rotation is determined
    dt = sol.X[:3, 3] - X[:3, 3]
    assert np.linalg.norm(dt - (dt @ k) * k) < 1e-9   # in-plane translation is determined
    assert sol.certified                              # exact fit
    assert sol.degenerate                             # ... but the axis translation is not


def test_pure_translation():
    rng = np.random.default_rng(24)
    X = random_X(rng)
    C = np.tile(np.eye(4), (12, 1, 1))
    C[:, :3, 3] = rng.normal(size=(12, 3))
    H = motions_from_C(C, X, rng, 1e-3, 1e-3)
    sol = simcalib.solve(C, H)
    # C rotations are exact identities: the translation of X is seen only through the
    # noise of H, i.e. (nearly) not at all
    assert sol.degenerate and sol.verdict in FLAGGED
    tr = _translation_dirs(sol)
    assert len(tr) == 3                               # translation in every direction
    assert np.all(sol.std[3:] > 0.1)
    assert "only translates" in sol.observability.motion
    assert g.rotation_error_rad(sol.X, X) < np.radians(1.0)   # rotation still determined


def test_single_axis_screw_motion():
    """Rotations about one axis with translations having components along it."""
    rng = np.random.default_rng(25)
    k = np.array([1.0, -1.0, 0.5]) / 1.5
    ang = rng.uniform(-2.0, 2.0, 20)
    C = g.transform_from_rotation_translation(g.matrix_from_rotvec(ang[:, None] * k),
                                              rng.normal(size=(20, 3)))
    X = random_X(rng)
    sol = simcalib.solve(C, motions_from_C(C, X, rng, 1e-3, 1e-3))
    tr = _translation_dirs(sol)
    assert sol.degenerate and tr
    assert any(abs(d.translation_dir_a @ k) > 0.99 for d in tr)
    assert "single rotation axis" in sol.observability.motion


def test_noisy_near_planar_is_poorly_determined_with_sigma():
    rng = np.random.default_rng(26)
    C, H, X, k = planar_case(rng, n=40, axis=[0.0, 0.0, 1.0])
    C = g.perturb_transforms(C, 0.003, 0.0, rng)          # slightly non-planar
    H = motions_from_C(C, X, rng, 0.01, 0.01)              # noisy
    sol = simcalib.solve(C, H)
    assert sol.degenerate
    tr = [d for d in _translation_dirs(sol) if abs(d.translation_dir_a @ k) > 0.9]
    assert tr and tr[0].std_m > 0.01                        # beyond the 1 cm tolerance
    assert sol.std[5] > 0.01 and sol.std[3] < sol.std[5]   # vertical worst
    assert "poorly determined" in sol.message or "undetermined" in sol.message
    # the tolerance decides: a loose one accepts the same data
    loose = simcalib.solve(C, H, tolerance_m=10.0, tolerance_deg=30.0)
    assert loose.undetermined == () or all(d.reason == "undetermined"
                                           for d in loose.undetermined)


def test_prior_determines_the_free_direction():
    rng = np.random.default_rng(27)
    C, H, X, k = planar_case(rng, n=25, axis=[0.0, 0.0, 1.0], sigma_r=0.005, sigma_t=0.005)
    sol = simcalib.solve(C, H, prior=Prior(X=X, a=1.0, b=1.0))
    assert sol.degenerate                                  # the motions alone do not fix it
    assert sol.undetermined and all(d.determined_by_prior for d in sol.undetermined)
    assert "fixed by the prior" in sol.message
    assert abs(sol.X[2, 3] - X[2, 3]) < 0.01
    assert np.isfinite(sol.std).all()                      # with the prior: finite sigma


def test_failed_solution_is_degenerate_and_has_no_verdict():
    rng = np.random.default_rng(28)
    C, H, X = general_case(rng, n=10)
    sol = simcalib.solve(C, H)
    bad = type(sol)(**{**{f: getattr(sol, f) for f in sol.__dataclass_fields__},
                       "success": False, "X": np.full((4, 4), np.nan)})
    assert bad.uncertainty is None and bad.degenerate and bad.verdict == "FAILED"
    assert bad.undetermined == () and "FAILED" in bad.message
    assert bad.to_dict()["X"] is None
