"""docs/advice.md's generator (simcalib.studies.advise.tables): pooling rigs and the table rows,
on hand-made verifications (the full command runs the simulator for half an hour)."""

import numpy as np
import pytest

from simcalib.studies.advise import tables
from simcalib.studies.advise.verification import Verification


def _r(rot, trans, sd=0.1, scm=0.2, verdict="determined"):
    return {"success": True, "rotation_error_deg": rot, "translation_error_cm": trans,
            "max_std_deg": sd, "max_std_cm": scm, "verdict": verdict}


def _ver(adv, rand, hind):
    med = {"rotation_error_deg": float(np.median([r["rotation_error_deg"] for r in rand]))}
    return Verification(baseline=_r(1.0, 10.0), advised=adv[0], random=rand,
                        random_median=med, ratio={}, timing_s={}, advised_seeds=adv,
                        hindsight=hind, motion_size={"advised": None})


def test_pool_takes_medians_over_every_rig_and_seed_and_the_hindsight_bound():
    v0 = _ver([_r(0.1, 0.2), _r(0.3, 0.4)], [_r(1.0, 2.0, 0.4, 0.8), _r(2.0, 4.0, 0.4, 0.8)],
              _r(0.05, 0.1))
    v1 = _ver([_r(0.2, 0.3)], [_r(3.0, 6.0, 0.4, 0.8)], _r(0.15, 0.3))
    p = tables.pool([v0, v1])
    assert p.advised_median["rotation_error_deg"] == 0.2          # of 0.1, 0.3, 0.2
    assert p.random_median["rotation_error_deg"] == 2.0           # of 1, 2, 3
    assert p.ratio["translation_error_cm"] == 0.3 / 4.0
    assert p.hindsight_median["rotation_error_deg"] == 0.1        # of 0.05, 0.15
    assert np.isclose(p.ratio_hindsight["rotation_error_deg"], 0.1 / 2.0)
    row = tables._bound_row("scara", p)
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[0] == "scara" and cells[2] == "0.1 / 0.2" and cells[4] == "0.1 / 0.075"
    assert cells[5] == "0.05 / 0.05"
    assert cells[6] == "0.25 / 0.25"          # predicted sigma: 0.1 / 0.4 and 0.2 / 0.8
    assert tables._verdicts(p) == "determined (3/3 determined)"


def test_pool_without_a_hindsight_bound_leaves_its_cells_empty():
    v = _ver([_r(0.1, 0.2)], [_r(1.0, 2.0)], {})
    p = tables.pool([v])
    assert p.hindsight_median == {} and p.ratio_hindsight == {}
    cells = [c.strip() for c in tables._bound_row("x", p).strip("|").split("|")]
    assert cells[2] == "n/a" and cells[5] == "n/a"


def test_ranking_row_takes_medians_over_the_rigs():
    from types import SimpleNamespace
    advs = [SimpleNamespace(cannot_help=[], random_chains=np.zeros((200, 5), int),
                            random_chains_std=np.tile(np.r_[r, r, r, 0.01, 0.01, 0.02], (200, 1)),
                            std_after=np.array([[0.1, 0.05, 0.05, 0.004, 0.004, 0.004]]))
            for r in (0.2, 0.5, 0.4)]                 # expected ratio 0.5, 0.2, 0.25
    rk = [{"spearman_rotation": 0.2, "spearman_translation": 0.3,
           "best_tenth_over_all_rotation": 0.9, "best_tenth_over_all_translation": 0.8},
          {"spearman_rotation": 0.4, "spearman_translation": None,
           "best_tenth_over_all_rotation": 0.7, "best_tenth_over_all_translation": None},
          {}]
    vers = [_ver([_r(0.1, 0.2)], [_r(1.0, 2.0)], {"ranking": d} if d else {}) for d in rk]
    pooled = SimpleNamespace(ratio_wide={"rotation_error_deg": 0.6, "translation_error_cm": 0.7})
    cells = [c.strip() for c in tables._ranking_row("scara", advs, vers, pooled)
             .strip("|").split("|")]
    assert cells[1] == "0.25 / 0.2"          # medians of (0.5, 0.2, 0.25) and (0.2, 0.2, 0.2)
    assert cells[2] == "0.6 / 0.7"
    assert cells[3] == "0.3 / 0.3"           # rigs without a ranking are left out
    assert cells[4] == "0.8 / 0.8"


@pytest.mark.slow
def test_ratio_interval_bootstraps_the_rigs():
    """The pooled ratio's interval over resampled rigs: a point when every rig gives the
    same results, a spread that contains the pooled ratio when rigs differ, deterministic,
    and bad arguments refused."""
    import pytest
    same = [_ver([_r(0.1, 0.2)], [_r(1.0, 1.0)], None) for _ in range(4)]
    iv = tables.ratio_interval(same)
    assert iv["rotation_error_deg"] == pytest.approx((0.1, 0.1))
    assert iv["translation_error_cm"] == pytest.approx((0.2, 0.2))
    vers = [_ver([_r(a, 2 * a)], [_r(1.0, 1.0)], None) for a in (0.1, 0.2, 0.4, 0.8, 1.6)]
    p = tables.pool(vers)
    lo, hi = p.ratio_interval["rotation_error_deg"]
    assert lo < p.ratio["rotation_error_deg"] == 0.4 < hi          # median of 0.1 .. 1.6
    assert 0.1 <= lo and hi <= 1.6
    assert tables.ratio_interval(vers) == tables.ratio_interval(vers)
    lo50, hi50 = tables.ratio_interval(vers, level=0.5)["rotation_error_deg"]
    assert lo <= lo50 < hi50 <= hi and (lo50, hi50) != (lo, hi)     # the level is used
    assert tables.ratio_interval(vers[:1]) == {}
    assert tables._interval(p.ratio_interval) == \
        f"{tables._fmt(lo, 2)}-{tables._fmt(hi, 2)} / " + "-".join(
            tables._fmt(x, 2) for x in p.ratio_interval["translation_error_cm"])
    assert tables._interval({}) == "n/a / n/a"
    with pytest.raises(ValueError, match="n_boot must be an integer >= 1; received 0"):
        tables.ratio_interval(vers, n_boot=0)
    with pytest.raises(ValueError, match=r"level must be in \(0, 1\); received 1.5"):
        tables.ratio_interval(vers, level=1.5)


def test_verdict_cell_is_the_same_in_every_process():
    """A tie between verdicts is broken by name, not by the process's hash seed."""
    from types import SimpleNamespace
    for v in (["undetermined", "determined"], ["determined", "undetermined"]):
        assert tables._verdicts(SimpleNamespace(verdicts=v)) == "determined (1/2 determined)"
    assert tables._verdicts(SimpleNamespace(verdicts=[None])) == "n/a"


def _floor(rr, rt, adv=(0.1, 0.2), spread=(1.0, 1.0)):
    rnd = (0.4, 0.8)
    return {"advised_expected_deg": adv[0], "advised_expected_cm": adv[1],
            "floor_expected_deg": rr * rnd[0], "floor_expected_cm": rt * rnd[1],
            "random_expected_deg": rnd[0], "random_expected_cm": rnd[1],
            "ratio_advised_rotation": adv[0] / rnd[0],
            "ratio_advised_translation": adv[1] / rnd[1],
            "ratio_floor_rotation": rr, "ratio_floor_translation": rt,
            "floor_per_start_deg": [rr * rnd[0], rr * rnd[0] * spread[0]],
            "floor_per_start_cm": [rt * rnd[1], rt * rnd[1] * spread[1]]}


def test_floor_summary_row_and_target_clause():
    """Medians over the rigs, each rig's floor ratios, the largest search spread; the
    target clause names the blocks whose floor is above the target; rigs without a floor
    (fewer stops than k) are left out."""
    s = tables.floor_summary([_floor(0.5, 0.2, spread=(1.1, 1.0)), {},
                              _floor(0.3, 0.4, spread=(1.0, 1.05)), _floor(0.4, 0.3)])
    assert s["rigs"] == 3 and s["ratio_floor_rotation"] == 0.4
    assert s["ratio_floor_translation"] == 0.3 and s["random_expected_cm"] == 0.8
    assert s["per_rig"] == [(0.5, 0.2), (0.3, 0.4), (0.4, 0.3)]
    assert np.allclose(s["spread"], (1.1, 1.05))
    v = tables.pool([_ver([_r(0.1, 0.2)], [_r(0.2, 0.4)], {})])
    cells = [c.strip() for c in tables._floor_row("scara", s, v).strip("|").split("|")]
    assert cells[2] == "0.16 / 0.24" and cells[5] == "0.4 / 0.3"
    assert cells[6] == "0.5/0.2 0.3/0.4 0.4/0.3" and cells[7] == "1.100 / 1.050"
    assert cells[9] == "1 / 1" and cells[10] == "0.5 / 0.5"  # actual 0.1 / 0.2, 0.2 / 0.4
    assert "on rotation and translation" in tables._floor_target(s, 0.29)
    assert tables._floor_target(s, 0.35).endswith("reach the target on rotation")
    assert "expected to reach the target" in tables._floor_target(s, 0.5)
    assert tables.floor_summary([{}, {}]) == {} and tables._floor_target({}, 0.3) == ""
    # a block some rig leaves undetermined has no median and never reaches a target
    und = dict(_floor(0.4, 0.3), floor_expected_cm=None, ratio_floor_translation=None)
    s = tables.floor_summary([und, _floor(0.2, 0.2)])
    assert s["ratio_floor_translation"] is None
    assert s["ratio_floor_rotation"] == pytest.approx(0.3)
    assert tables._floor_target(s, 0.5).endswith("reach the target on translation")
    import dataclasses
    v = dataclasses.replace(_ver([_r(0.1, 0.2)], [_r(1.0, 2.0)], {}),
                            ratio={"rotation_error_deg": 0.1, "translation_error_cm": 0.1})
    cells = [c.strip() for c in tables._floor_row("x", {}, v).strip("|").split("|")]
    assert cells[1:8] == ["n/a"] * 7 and cells[8] == "0.1 / 0.1" and cells[9:] == ["n/a"] * 2
