"""The real-data regression suite (issue 28): every public recording of the table
``simcalib.studies.experiments.real_sets.SETS``, calibrated once per session with the ``calibrate``
defaults, against its README's "correct" (docs/real-data.md). Skipped per set when its data
are absent (``SIMCALIB_REAL_DIR`` / ``SIMCALIB_ETH_DIR``)."""

import math

import numpy as np
import pytest

from simcalib.errors import DataError
from simcalib.studies.experiments import real_checks as checks
from simcalib.studies.experiments import real_data as rd
from simcalib.studies.experiments import real_data_doc as doc
from simcalib.studies.experiments import real_sets as sets

# every test of this file shares one calibration per set: keep them on one xdist worker
pytestmark = pytest.mark.xdist_group("real_data")


def _ids(entries):
    return [e.name for e in entries]


REFERENCED_OR_TIMED = [e for e in sets.SETS if e.reference is not None
                       or (e.tolerance is not None and e.tolerance.offset_s is not None)]
FLAGGED = [e for e in sets.SETS if e.required_flags]


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """``result(entry)``: the set's :class:`SetResult`, calibrated at most once per module
    (skips when the data are absent)."""
    cache, done = tmp_path_factory.mktemp("eth_cache"), {}

    def get(entry):
        ok, why = sets.set_available(entry)
        if not ok:
            pytest.skip(why)
        if entry.name not in done:
            done[entry.name] = checks.run_set(entry, cache_dir=cache)
        return done[entry.name]
    return get


# ------------------------------------------------------------------------ fast units
def test_nees_pseudo_inverse_on_the_determined_axes():
    """Axis vz undetermined (inf), vx and vy perfectly correlated (rank 1 there): the NEES
    uses the 5 finite axes, pseudo-inverts the rank-4 block and reports dof 4."""
    S = np.diag([1e-4, 4e-4, 9e-4, 1e-6, 1e-6, np.inf])
    S[3, 4] = S[4, 3] = 1e-6                         # vx == vy: one direction
    cov = [[None if not math.isfinite(x) else x for x in row] for row in S]
    e = np.array([1e-2, -2e-2, 3e-2, 1e-3, 1e-3, 5.0])  # vz error is ignored
    n = checks.nees(e, cov)
    # by hand: the rotation axes 1 each, (vx + vy) / sqrt 2 = sqrt2 mm over variance 2e-6
    assert n.dof == 4 and n.axes == (0, 1, 2, 3, 4)
    assert n.value == pytest.approx(3.0 + (2e-3 / math.sqrt(2)) ** 2 / 2e-6)
    assert n.bound_95 == pytest.approx(9.4877, abs=1e-4)
    # an error across the correlated pair is outside the determined subspace: not counted
    assert checks.nees(np.array([0, 0, 0, 1e-3, -1e-3, 0.0]), cov).value == pytest.approx(0.0)
    # the reference's own covariance adds to the estimate's; axes may be restricted
    extra = np.diag([1e-4, 4e-4, 9e-4, 0, 0, 0])
    assert checks.nees(e, cov, sets.ROTATION_ONLY, extra).value == pytest.approx(1.5)
    assert checks.nees(e, cov, sets.ROTATION_ONLY).dof == 3
    assert checks.nees(e, None) is None
    assert checks.chi2_bound_95(6) == pytest.approx(12.59, abs=0.005)


def test_nees_is_chi_square_on_simulated_errors():
    """Errors drawn from the covariance give NEES below the 95 % bound ~95 % of the time."""
    rng = np.random.default_rng(28)
    A = rng.normal(size=(6, 6))
    S = A @ A.T * 1e-4
    e = rng.multivariate_normal(np.zeros(6), S, size=1000)
    share = np.mean([checks.nees(x, S).within for x in e])
    assert 0.925 < share < 0.975


def test_loop_covariance_propagates_undetermined_axes():
    J = np.eye(6)
    J[3:, :3] = np.ones((3, 3))
    S = np.diag([1.0, 1, 1, 1, 1, np.inf])
    P = checks.propagate_covariance(J, S)
    assert np.isinf(P[5, 5]) and np.isfinite(P[:5, :5]).all()
    assert P[3, 3] == pytest.approx(4.0)            # 3 rotation axes + vx


def _constructed(entry, X, flagged=(), offset_s=0.0):
    ref = sets.Reference(np.eye(4), "identity", "test")
    e, rot, trans = checks._reference_errors(ref, X, entry)
    return checks.SetResult(entry.name, 6, "degenerate", "", 0.0, X=X, flagged=flagged,
                        offset_s=offset_s, reference=ref, error_vector=e,
                        rotation_error_deg=rot, translation_error_mm=trans)


def test_checks_on_constructed_results():
    """The required flag must match in axis (undetermined or poorly determined: not
    determined); a flagged translation waives the translation tolerance only where the
    README says so; the offset is checked."""
    scara, fr1, fr2 = (sets.set_by_name(n) for n in ("scara_handeye4dof", "tum_fr1_xyz_rgbdslam",
                                                     "tum_fr2_desk_orb"))
    z = checks.FlaggedDirection("undetermined", "translation", (0.0, 0, 0), (0.0, 0.1, -0.99), "")
    assert checks.flag_check(scara, _constructed(scara, np.eye(4), (z,)))[0]
    poor = checks.FlaggedDirection("poorly determined", "translation", (0.0, 0, 0), (0, 0, 1.0), "")
    assert checks.flag_check(scara, _constructed(scara, np.eye(4), (poor,)))[0]
    x = checks.FlaggedDirection("undetermined", "translation", (0.0, 0, 0), (1.0, 0, 0), "")
    ok, why = checks.flag_check(scara, _constructed(scara, np.eye(4), (x,)))
    assert not ok and "hand z" in why
    assert not checks.flag_check(scara, _constructed(scara, np.eye(4), ()))[0]
    X = np.eye(4)
    X[:3, 3] = [0.0, 0.05, 0.0]                       # 50 mm off the identity
    assert not checks.tolerance_check(fr1, _constructed(fr1, X))[0]
    assert checks.tolerance_check(fr1, _constructed(fr1, X, (x,)))[0]
    assert not checks.tolerance_check(fr2, _constructed(fr2, X, (x,)))[0]
    ok, why = checks.tolerance_check(fr2, _constructed(fr2, np.eye(4), offset_s=0.2))
    assert not ok and "offset" in why
    assert checks.tolerance_check(fr2, _constructed(fr2, np.eye(4), offset_s=0.01))[0]


def test_the_table_names_are_unique_and_resolvable():
    names = [e.name for e in sets.SETS]
    assert len(set(names)) == len(names)
    for a, b in sets.CROSS_SET_PAIRS:
        assert sets.set_by_name(a).name == a and sets.set_by_name(b).name == b
    with pytest.raises(Exception, match="kuka_1"):
        sets.set_by_name("rwhecalib_kuka1")


@pytest.mark.parametrize("entry", [e for e in sets.SETS if e.reference in ("file", "readme")],
                         ids=_ids([e for e in sets.SETS if e.reference in ("file", "readme")]))
def test_references_parse_from_the_set_files(entry):
    ok, why = sets.set_available(entry)
    if not ok:
        pytest.skip(why)
    ref = sets.load_reference(entry)
    R = ref.T_a_b[:3, :3]
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-5) and np.linalg.det(R) > 0
    if entry.name.startswith("crwhe"):
        assert ref.spread_deg is not None and ref.covariance is not None
        assert sets.reference_tolerance(entry, ref) == (ref.spread_deg, ref.spread_m)
    if entry.reference == "readme":                 # scara: t and Euler xyz [180, 0, 0]
        assert np.allclose(ref.T_a_b[:3, 3], [-0.456, -0.037, -0.112])
        assert np.allclose(R, np.diag([1.0, -1.0, -1.0]), atol=1e-12)


# ------------------------------------------------------------- the sets, the defaults
@pytest.mark.slow
@pytest.mark.parametrize("entry", sets.SETS, ids=_ids(sets.SETS))
def test_defaults_give_a_result(entry, result):
    """No refusal, no crash: exit 0 (determined) or 6 (degenerate) on every set."""
    r = result(entry)
    assert r.exit_code in (0, 6), f"exit {r.exit_code}: {r.error}"
    assert r.X is not None and np.isfinite(r.X).all()


@pytest.mark.slow
@pytest.mark.parametrize("entry", REFERENCED_OR_TIMED, ids=_ids(REFERENCED_OR_TIMED))
def test_within_the_readme_tolerance(entry, result):
    """X within the README's "correct" of the reference (crwhe: the reference's spread;
    kuka / sthe: of OpenCV PARK on the files), and the offset where one is known."""
    ok, why = checks.tolerance_check(entry, result(entry))
    assert ok, why


@pytest.mark.slow
@pytest.mark.parametrize("entry", FLAGGED, ids=_ids(FLAGGED))
def test_required_directions_are_flagged(entry, result):
    """scara: translation along hand z undetermined; kitti: translation along cam0 y."""
    ok, why = checks.flag_check(entry, result(entry))
    assert ok, why


@pytest.mark.slow
def test_nees_within_its_bound_on_80_percent_of_the_referenced_sets(result):
    """On the sets with an independent reference, the NEES (with the reference's stated
    spread added where it states one) is within the chi-square 95 % bound on >= 80 %;
    a set that does not run, or has no covariance, counts as outside."""
    entries = [e for e in sets.SETS if e.independent_reference and sets.set_available(e)[0]]
    if not entries:
        pytest.skip("no referenced set present")
    rows = {e.name: result(e).nees_target for e in entries}
    inside = [n for n, v in rows.items() if v is not None and v.within]
    share = len(inside) / len(rows)
    detail = {n: (None if v is None else (round(v.value, 2), v.dof)) for n, v in rows.items()}
    assert share >= sets.NEES_TARGET_SHARE, f"{share:.0%} within: {detail}"


@pytest.mark.slow
def test_the_recordings_halves_agree_within_the_reported_sigma_on_most_sets(result):
    """The reference-free check: X of each recording's first half against its second,
    within the 95 % bound of the difference the pose-error model predicts, on >= 80 % of
    the sets whose halves could be compared (the others have their sigma scaled up)."""
    rows = {e.name: result(e).split for e in sets.SETS if sets.set_available(e)[0]}
    rows = {n: v for n, v in rows.items() if v is not None}
    if not rows:
        pytest.skip("no set present")
    inside = [n for n, v in rows.items() if v.within]
    detail = {n: round(v.value, 1) for n, v in rows.items() if not v.within}
    assert len(inside) >= 0.8 * len(rows), f"{len(inside)} of {len(rows)}: {detail}"


@pytest.mark.slow
@pytest.mark.parametrize("pair", sets.CROSS_SET_PAIRS, ids=["-".join(p) for p in sets.CROSS_SET_PAIRS])
def test_sets_sharing_a_mount_agree_within_3_combined_sigma(pair, result):
    """The two X differ by at most 3 combined (summed-covariance) sigma on every axis the
    two estimates determine."""
    r1, r2 = (result(sets.set_by_name(n)) for n in pair)
    g = checks.agreement(r1, r2)
    assert g.ok, g.message + f"; ratios {None if g.ratio is None else np.round(g.ratio, 2)}"


@pytest.mark.slow
@pytest.mark.parametrize("loop", sets.LOOPS, ids=["-".join(lp) for lp in sets.LOOPS])
def test_three_streams_of_one_rig_close_the_loop(loop, result):
    """X_ac = X_ab X_bc within 3 combined sigma on every determined axis."""
    g = checks.loop_agreement(*(result(sets.set_by_name(n)) for n in loop))
    assert g.ok, g.message + f"; ratios {None if g.ratio is None else np.round(g.ratio, 2)}"


@pytest.mark.slow
def test_the_document_reports_every_set_it_was_given(result):
    entries = [e for e in sets.SETS if e.independent_reference and sets.set_available(e)[0]][:2]
    if not entries:
        pytest.skip("no referenced set present")
    results = {e.name: result(e) for e in entries}
    text = doc.markdown(results, command="python -m simcalib.studies.experiments.real_data",
                       total_time_s=1.0)
    s = checks.summarise(results)
    assert all(f"| {n} |" in text for n in results)
    assert f"**{s.n_ran} of {len(results)}** sets exit 0 or 6" in text
    assert "python -m simcalib.studies.experiments.real_data" in text


def test_missing_data_is_reported_with_the_variable_to_set(monkeypatch, tmp_path):
    monkeypatch.setenv(sets.REAL_ENV, str(tmp_path / "none"))
    monkeypatch.setenv(sets.ETH_ENV, str(tmp_path / "none"))
    for entry in sets.SETS:
        ok, why = sets.set_available(entry)
        assert not ok and (sets.REAL_ENV in why or sets.ETH_ENV in why)
    with pytest.raises(DataError, match="SIMCALIB_REAL_DIR"):
        rd.run_sets()
