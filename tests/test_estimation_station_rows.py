"""Station rows paired by the equal-angle rule where a file lost a row and the rest were
renumbered (simcalib.estimation.station_rows)."""

from dataclasses import replace

import numpy as np
import pytest

from simcalib.estimation.path import calibrate_streams
from simcalib.estimation.sampling import classify_sampling
from simcalib.estimation.station_rows import align_rows, realign_rows
from simcalib.geometry import (random_rotation_matrices, rotation_error_rad,
                               transform_from_rotation_translation)
from simcalib.studies.experiments.recording_kinds import generate


def _lost_row(stream, k):
    """``stream`` without row ``k``, the later rows renumbered (stamps of the first rows)."""
    t = np.asarray(stream.timestamps_s)
    T = np.delete(np.asarray(stream.T_world_sensor), k, axis=0)
    return replace(stream, timestamps_s=t[:T.shape[0]], T_world_sensor=T)


def test_align_rows_finds_the_lost_row():
    rng = np.random.default_rng(0)
    n = 20
    T_a = transform_from_rotation_translation(random_rotation_matrices(rng, (n,)),
                                              rng.normal(size=(n, 3)))
    X = T_a[0] @ np.linalg.inv(T_a[1])
    T_b = np.delete(T_a @ X, 7, axis=0)          # b lost row 7
    ia, ib = align_rows(T_a, T_b)
    assert np.array_equal(ia, np.delete(np.arange(n), 7))
    assert np.array_equal(ib, np.arange(n - 1))


@pytest.mark.parametrize("seed", [0, 2])        # stations stamped by index (even seeds)
def test_a_lost_and_renumbered_row_is_paired_by_motion(seed):
    rec = generate("stations", seed)
    k = rec.stream_b.timestamps_s.size // 3
    base = calibrate_streams(rec.stream_a, rec.stream_b)
    lost = calibrate_streams(rec.stream_a, _lost_row(rec.stream_b, k))
    assert base.summary["station_rows"] == []
    assert len(lost.summary["station_rows"]) == 1
    assert "do not pair by number" in lost.summary["station_rows"][0]
    assert lost.stream_a.repairs["rows_without_a_partner"] == 1
    assert lost.stream_b.repairs["rows_paired_by_motion"] == k + (rec.stream_b.timestamps_s.size
                                                                  - k - 1)
    assert np.degrees(rotation_error_rad(lost.X, rec.X_true)) < 0.2
    assert np.linalg.norm(lost.X[:3, 3] - rec.X_true[:3, 3]) < 3e-3


def test_paired_streams_and_streams_stamped_in_time_are_left_as_they_are():
    rec = generate("stations", 0)
    sa, sb = rec.stream_a, rec.stream_b
    smp = classify_sampling(sa, sb)
    assert realign_rows(sa, sb, smp) == (sa, sb, smp, [])
    odd = generate("stations", 1)                 # stamps seconds apart, not numbers
    sb1 = _lost_row(odd.stream_b, 3)
    smp1 = classify_sampling(odd.stream_a, sb1)
    assert realign_rows(odd.stream_a, sb1, smp1)[3] == []
