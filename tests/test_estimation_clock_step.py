"""A clock that steps once mid-recording (simcalib.estimation.clock_step): told where the
offset is constant on two stretches with a jump between them, located, removed from b's
stamps; never told on one clock or on a drift."""

from dataclasses import replace

import numpy as np
import pytest

from simcalib.estimation import clock_step
from simcalib.estimation.alignment import estimate_time_offset
from simcalib.estimation.clock_step import edge_run, find_step, two_levels
from simcalib.estimation.path import calibrate_streams
from simcalib.geometry import rotation_error_rad
from simcalib.report.calibration import _step_line
from simcalib.studies.experiments.recording_kinds import generate
from simcalib.world.stream_sim import rig_streams


def _stepped(rec, size_s, frac=0.5):
    """The recording's b with its stamps from row ``frac`` of it on moved by ``size_s``
    (sorted, as the reader sorts them), and that row's stamp as written."""
    sb = rec.stream_b
    t = np.asarray(sb.timestamps_s, np.float64).copy()
    k = int(t.size * frac)
    t[k:] += size_s
    order = np.argsort(t, kind="stable")
    return replace(sb, timestamps_s=t[order], T_world_sensor=sb.T_world_sensor[order]), t[k]


def test_two_levels_of_the_parts():
    t = [10.0, 20.0, 30.0, 40.0]
    sig = [1e-3] * 4
    assert two_levels(t, [0.0, 0.0, 0.4, 0.4], sig) == (1, 2)
    assert two_levels(t, [0.0, 0.001, 0.4, 0.401], sig) == (1, 2)
    assert two_levels(t, [0.0, 0.01, 0.02, 0.03], sig) is None        # a drift: a line
    assert two_levels(t, [0.0, 0.0005, -0.0005, 0.0], sig) is None    # one offset
    assert two_levels(t[:2], [0.0, 0.4], sig[:2]) is None              # too few parts
    # a part left out between the groups only where it lies between them (a part that
    # holds the step mixes the two offsets); tum_fr1_xyz's parts (ms) are no step
    assert two_levels(t, [0.0, 0.25, 0.4, 0.4], sig) == (0, 2)
    assert two_levels(t, [0.01195, 0.00083, 0.00727, 0.0071], sig) is None


def test_parts_at_their_brackets_edge_as_one_run_at_an_end():
    """TUM fr2/desk with b +0.4 s half-way: parts 340.9, 340.9 (the bracket's edge, one
    offset at 405 ms), 407.6, 403.0 ms; the two levels' test alone misses it (the fitted
    half's parts 4.6 ms apart at 0.5 ms sigmas), the run of edge parts does not."""
    assert edge_run([True, True, False, False]) == (1, 2)
    assert edge_run([False, False, False, True]) == (2, 3)
    assert edge_run([False, True, False, False]) is None     # not at an end
    assert edge_run([True, False, False, True]) is None      # two runs
    assert edge_run([False] * 4) is None and edge_run([True] * 4) is None


@pytest.mark.slow
@pytest.mark.parametrize("kind, seed, frac", [("offset", 0, 0.5), ("outliers", 0, 0.37)])
def test_a_clock_step_is_told_located_and_removed(kind, seed, frac):
    """b's clock jumps by +0.4 s (half-way, or inside a part of the split check with 10 %
    outlier poses): one step of 0.4 s is told at the right stamp, both offsets within a
    few ms, and X as without the step (one offset: X degrees off or poorly determined)."""
    rec = generate(kind, seed)
    sb, at = _stepped(rec, 0.4, frac)
    r = calibrate_streams(rec.stream_a, sb)
    off = r.time_offset
    assert len(off.steps) == 1, off.message
    st = off.steps[0]
    assert st.at_b_s == at
    assert abs(st.size_s - 0.4) < max(2e-3, 3 * st.size_sigma_s) and st.size_sigma_s < 2e-3
    assert abs(st.before_s - rec.offset_s) < 3e-3
    assert abs(st.after_s - rec.offset_s - 0.4) < 3e-3
    assert abs(off.offset_s - rec.offset_s) < 3e-3 and off.drift == 0.0
    assert np.degrees(rotation_error_rad(r.X, rec.X_true)) < 0.05
    assert np.linalg.norm(r.X[:3, 3] - rec.X_true[:3, 3]) < 1e-3
    assert r.stream_b.repairs["clock_step_rows_shifted"] == st.rows_shifted
    line = _step_line(st.to_dict())
    assert line.startswith("CLOCK STEP of b: +") and "a clock step, not a drift" in line
    assert st.line() in off.message


@pytest.mark.slow
def test_no_step_on_one_clock():
    """The same recording without a step: nothing new (the search is not even run where
    the split check holds)."""
    rec = generate("offset", 0)
    r = calibrate_streams(rec.stream_a, rec.stream_b)
    assert r.time_offset.steps == ()
    assert "clock_step_rows_shifted" not in r.stream_b.repairs


def test_a_drift_is_no_step():
    """100 ppm over 40 s fitted as one offset: the split check raises (its parts climb)
    and the search runs, but the parts lie on a line: no step; with the drift fitted the
    search does not run."""
    rs = rig_streams(offset_s=0.1, drift=100e-6, duration_s=40.0, rng=np.random.default_rng(3))
    one = estimate_time_offset(rs.a, rs.b, drift=False)
    assert one.split.raised and one.drift == 0.0
    assert find_step(rs.a, rs.b, one, alpha=1.0, signal="auto") is None
    est = estimate_time_offset(rs.a, rs.b)
    assert est.drift != 0.0 and not clock_step._may_step(est)


def test_a_step_on_simulated_streams_is_found_by_find_step():
    """``find_step`` alone: a rig at 30 / 20 Hz, b's clock +0.25 s from its middle on."""
    rs = rig_streams(offset_s=0.05, duration_s=40.0, rng=np.random.default_rng(4))
    t = rs.t_b.copy()
    k = t.size // 2
    t[k:] += 0.25
    one = estimate_time_offset(rs.a, (t, rs.T_b))
    st = find_step(rs.a, (t, rs.T_b), one, alpha=1.0, signal="auto")
    assert st is not None, one.message
    assert st.at_b_s == t[k] and abs(st.size_s - 0.25) < 1e-3
    assert abs(st.before_s - 0.05) < 1e-3 and st.rows_shifted == t.size - k


def test_a_step_of_seconds_is_searched_where_the_parts_after_it_are_flat():
    """b +2 s from its middle on (offset kind, 20 s): one offset fits the first half; the
    split check's parts after the step have no curvature within the bracket (no finite
    sigma) and were left out, so the check held and the search never ran. They are kept
    as flat parts, the run of them at the end bounds the step, and it is told at the
    right stamp, both offsets within a ms."""
    rec = generate("offset", 0)
    sb, at = _stepped(rec, 2.0)
    one = estimate_time_offset(rec.stream_a, sb)
    assert len(one.split.offsets_s) == 2 and len(one.split.flat_times_s) == 2
    assert not one.split.raised
    st = find_step(rec.stream_a, sb, one, alpha=1.0, signal="auto")
    assert st is not None and st.at_b_s == at
    assert abs(st.size_s - 2.0) < 2e-3 and abs(st.before_s - rec.offset_s) < 1e-3


def test_a_step_back_is_placed_after_the_interleaved_rows():
    """b's clock steps back by 0.43 s: sorted, the rows of both stretches interleave over
    the 0.43 s before the first row after the last one of the old clock. No stamp splits
    them; the step is put at that first row (motions ending among the interleaved rows fit
    neither offset and count in no term: they pulled it 0.35 s early)."""
    rs = rig_streams(offset_s=0.05, duration_s=40.0, rng=np.random.default_rng(4))
    t = rs.t_b.copy()
    k = t.size // 2
    last_before = t[k - 1]
    t[k:] -= 0.43                           # not a whole number of periods: no shared stamps
    order = np.argsort(t, kind="stable")
    b = (t[order], rs.T_b[order])
    one = estimate_time_offset(rs.a, b)
    st = find_step(rs.a, b, one, alpha=1.0, signal="auto")
    assert st is not None, one.message
    assert abs(st.size_s + 0.43) < 2e-3 and abs(st.before_s - 0.05) < 2e-3
    assert st.at_b_s == b[0][np.searchsorted(b[0], last_before, side="right")]


def _step(before_s, size_s, at_b_s=10.0, sigma_s=1e-3):
    return clock_step.ClockStep(at_b_s, at_b_s - before_s, size_s, sigma_s, before_s, sigma_s,
                                before_s + size_s, sigma_s, 1.0, 100.0, 100.0, 5)


def test_a_step_holds_where_the_offset_aligned_again_is_the_first_stretchs():
    from simcalib.estimation.alignment import _as_offset
    step = _step(-30.0, 0.4)
    assert clock_step.holds(step, _as_offset(-30.002))
    assert clock_step.holds(step, _as_offset(-29.97))          # within a tenth of the step
    assert not clock_step.holds(step, _as_offset(-29.9))
    assert not clock_step.holds(_step(-30.0, 152.6), _as_offset(-237.9))


@pytest.mark.slow
def test_a_step_that_does_not_hold_is_dropped(monkeypatch):
    """A step whose removal moves the whole alignment elsewhere explained nothing (KITTI
    with b 30 s late: a '+152 s step' over its last poses, then -238 s and X 179 deg
    off): the streams are taken as without it, to the bit."""
    rec = generate("offset", 0)
    plain = calibrate_streams(rec.stream_a, rec.stream_b)
    t_b = np.asarray(rec.stream_b.timestamps_s)
    wrong = _step(plain.time_offset.offset_s + 5.0, 3.0, at_b_s=float(t_b[int(0.9 * t_b.size)]))
    monkeypatch.setattr(clock_step, "find_step",
                        lambda a, b, off, **kw: None if off.steps else wrong)
    got = calibrate_streams(rec.stream_a, rec.stream_b)
    assert got.time_offset.steps == () and not got.stream_b.repairs.get("clock_step_rows_shifted")
    assert got.time_offset.offset_s == plain.time_offset.offset_s
    assert np.array_equal(got.X, plain.X)


def _told_step(rec):
    r = calibrate_streams(rec.stream_a, rec.stream_b)
    steps = r.time_offset.steps
    assert len(steps) == 1, r.time_offset.message
    assert steps[0].size_s == pytest.approx(rec.step_s, abs=3e-3)
    assert steps[0].at_a_s == pytest.approx(rec.step_at_s, abs=0.02)
    assert r.time_offset.offset_s == pytest.approx(rec.offset_s, abs=3e-3)
    assert r.summary["mount_change"] is None
    assert np.degrees(rotation_error_rad(r.X, rec.X_true)) < 0.1
    return r


def test_a_step_between_two_single_part_stretches_is_told():
    """20 s, a 1.03 s step at 60 %: each stretch's split check has one part, too few
    points to weigh a line; one would need a drift of ~10 %, no clock's (was: not told,
    then taken for a change of X)."""
    rec = generate("clock_step", 1)
    assert rec.step_s / (0.5 * (rec.stream_a.timestamps_s[-1]
                                - rec.stream_a.timestamps_s[0])) > clock_step.MAX_DRIFT
    _told_step(rec)


@pytest.mark.parametrize("seed", [2, 5])
def test_a_step_the_offsets_checks_miss_is_told_where_x_seemed_to_change(seed):
    """The offset fitted to one stretch, the other's motions dropped as outliers: the
    split check's parts agree, no step is looked for, and the mount check split the
    recording at the step (was: told as a change of X, seed 2 with the later stretch's
    offset, 1.2 s off)."""
    _told_step(generate("clock_step", seed))
