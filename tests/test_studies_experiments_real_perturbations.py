"""Known perturbations of the real recordings (simcalib.studies.experiments.real_perturbations)."""

import numpy as np
import pytest

from simcalib.studies.experiments import EXPERIMENTS
from simcalib.studies.experiments.real_perturbations import (PERTURBATIONS, UNIX_EPOCH_S,
                                                             _judge, perturb, run_sets,
                                                             shift_s)
from simcalib.studies.experiments.real_sets import real_dir


def _rows(n=20, seed=0):
    from simcalib.geometry import quat_from_matrix, random_rotation_matrices
    rng = np.random.default_rng(seed)
    q = quat_from_matrix(random_rotation_matrices(rng, (n,)))
    return np.column_stack([np.arange(n, dtype=float), rng.normal(size=(n, 3)), q])


def test_perturbations_do_what_they_say():
    a, b = _rows(), _rows(seed=1)
    rng = np.random.default_rng(0)
    _, bi = perturb("invert_b", a, b, rng)
    _, bii = perturb("invert_b", a, bi, rng)
    np.testing.assert_allclose(bii[:, 1:4], b[:, 1:4], atol=1e-12)
    assert np.allclose(np.abs(np.sum(bii[:, 4:8] * b[:, 4:8], axis=1)), 1.0)
    _, bw = perturb("wxyz_b", a, b, rng)
    assert np.array_equal(bw[:, 4], b[:, 7]) and np.array_equal(bw[:, 5:8], b[:, 4:7])
    _, bl = perturb("mirror_b", a, b, rng)                        # left-handed b
    assert np.array_equal(bl[:, [3, 4, 5]], -b[:, [3, 4, 5]])
    assert np.array_equal(bl[:, [0, 1, 2, 6, 7]], b[:, [0, 1, 2, 6, 7]])
    _, bm = perturb("mm_b", a, b, rng)
    assert np.allclose(bm[:, 1:4], 1000 * b[:, 1:4])
    _, bs = perturb("offset-30s", a, b, rng)
    assert np.allclose(bs[:, 0], b[:, 0] - 30.0)
    _, be = perturb("epoch_b", a, b, rng)                         # to Unix time and back
    assert np.allclose(be[:, 0], b[:, 0] + UNIX_EPOCH_S) and shift_s("epoch_b", b) > 1e9
    _, bz = perturb("epoch_b", a, be, rng)
    assert bz[0, 0] == 0.0 and np.allclose(bz[:, 0], b[:, 0] - b[0, 0])
    assert shift_s("epoch_b", be) == -be[0, 0] and shift_s("drop20%b", b) is None
    _, bl = perturb("lost_row_b", a, b, rng)                      # row n // 3 lost, renumbered
    k = len(b) // 3
    assert len(bl) == len(b) - 1 and np.array_equal(bl[:, 0], a[:len(b) - 1, 0])
    assert np.array_equal(bl[k:, 1:], b[k + 1:, 1:]) and np.array_equal(bl[:k], b[:k])
    _, bc = perturb("two_clocks_b", a, b, rng)                    # 2.3 s late, +-50 ms
    assert np.all(np.abs(bc[:, 0] - b[:, 0] - 2.3) <= 0.05) and np.array_equal(bc[:, 1:], b[:, 1:])
    assert np.array_equal(b, _rows(seed=1))                       # inputs untouched
    with pytest.raises(ValueError, match="unknown perturbation 'flip'; valid: base"):
        perturb("flip", a, b, rng)


def test_lost_rows_ab_loses_a_row_of_each_file_at_different_places():
    a, b = _rows(), _rows(seed=1)
    n = len(a)
    pa, pb = perturb("lost_rows_ab", a, b, np.random.default_rng(0))
    assert len(pa) == len(pb) == n - 1                            # every row pairs by number
    assert np.array_equal(pa[:, 0], a[:n - 1, 0]) and np.array_equal(pb[:, 0], a[:n - 1, 0])
    assert np.array_equal(pa[:, 1:], np.delete(a, 2 * n // 3, axis=0)[:, 1:])
    assert np.array_equal(pb[:, 1:], np.delete(b, n // 3, axis=0)[:, 1:])
    assert np.array_equal(a, _rows()) and np.array_equal(b, _rows(seed=1))


def _cal(X, clear=True, offset=0.0, sr=0.01, st=0.001):
    return {"X": {"T_a_b": X.tolist()}, "time_offset": {"offset_s": offset},
            "conventions": {"clear": clear},
            "uncertainty": {"std_rotation_deg": [sr] * 3, "std_translation_m": [st] * 3}}


def test_judge_tells_ok_flagged_and_failed():
    X0 = np.eye(4)
    X1 = np.eye(4)
    X1[:3, 3] = [0.05, 0, 0]                                     # 50 mm away
    base = _cal(X0)
    assert _judge("invert_b", base, 0, _cal(X0), "")[0] == "ok"
    assert _judge("invert_b", base, 6, _cal(X1), "")[0] == "FAIL"
    assert _judge("invert_b", base, 6, _cal(X1, clear=False), "")[0] == "flagged"
    assert _judge("offset+0.25s", base, 0, _cal(X0, offset=0.1), "")[0] == "FAIL"
    assert _judge("offset+0.25s", base, 0, _cal(X0, offset=0.2505), "")[0] == "ok"
    assert _judge("mm_b", base, 3, None, "simcalib: error: ... different units ...")[0] == "ok"
    assert _judge("mm_b", base, 3, None, "simcalib: error: something else")[0] == "FAIL"


def test_clock_step_b_steps_b_half_way_and_is_judged_on_the_step_told():
    """b's clock +0.4 s from its middle row on; ok only with one step of 0.4 s told (within
    3 ms or 3 of its sigma) and X staying."""
    a, b = _rows(), _rows(seed=1)
    pa, pb = perturb("clock_step_b", a, b, np.random.default_rng(0))
    n = len(b)
    assert np.array_equal(pa, a) and np.array_equal(pb[:, 1:], b[:, 1:])
    assert np.allclose(pb[:n // 2, 0], b[:n // 2, 0]) and np.allclose(pb[n // 2:, 0],
                                                                      b[n // 2:, 0] + 0.4)
    assert PERTURBATIONS["clock_step_b"] == (True, False)
    base = _cal(np.eye(4))

    def stepped(*steps):
        cal = _cal(np.eye(4))
        cal["time_offset"]["steps"] = [{"size_s": s, "size_sigma_s": g} for s, g in steps]
        return cal
    assert _judge("clock_step_b", base, 0, stepped((0.4012, 0.002)), "")[0] == "ok"
    assert _judge("clock_step_b", base, 0, stepped((0.39, 0.001)), "")[0] == "FAIL"
    assert _judge("clock_step_b", base, 6, stepped(), "")[0] == "FAIL"
    assert _judge("clock_step_b", base, 6, stepped((0.4, 0.001), (0.1, 0.001)), "")[0] == "FAIL"


def test_registered_as_an_experiment():
    assert "real_perturbations" in EXPERIMENTS
    assert set(PERTURBATIONS) >= {"invert_b", "mm_b", "offset-30s"}


@pytest.mark.skipif(not (real_dir() / "rwhecalib_kuka_1" / "a.txt").exists(),
                    reason="../shared/data/real is absent")
def test_a_station_set_sees_through_its_perturbations():
    names = ["invert_b", "wxyz_b", "mm_b", "shuffled_rows_b", "lost_row_b", "two_clocks_b",
             "mirror_b", "lost_rows_ab"]
    out = run_sets(["rwhecalib_kuka_1"], names)
    assert [o.perturbation for o in out] == names
    assert all(o.verdict == "ok" for o in out), out


def test_the_offset_may_move_by_the_shift_within_either_runs_sigma():
    base, shifted = _cal(np.eye(4)), _cal(np.eye(4), offset=0.2549)
    assert _judge("offset+0.25s", base, 6, shifted, "")[0] == "FAIL"     # 4.9 ms > 3 ms
    base["time_offset"]["uncertainty_s"] = 0.0053                        # not told: +-5.3
    assert _judge("offset+0.25s", base, 6, shifted, "")[0] == "ok"
