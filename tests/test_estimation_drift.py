"""The drift line through the split check's parts (simcalib.estimation.drift)."""

import numpy as np
import pytest

from simcalib.estimation.drift import DRIFT_MIN_PARTS, drift_line
from simcalib.estimation.offset_cost import SplitCheck


def _split(offsets_ms, sigma_ms=0.1, raised=True, times=(10.0, 30.0, 50.0, 70.0)):
    o = np.asarray(offsets_ms) * 1e-3
    w = 1.0 / (sigma_ms * 1e-3) ** 2
    ratio = float(np.sum(w * (o - o.mean()) ** 2) / (o.size - 1))
    return SplitCheck(tuple(o), (sigma_ms * 1e-3,) * o.size, ratio, float("nan"), raised,
                      tuple(times[:o.size]))


def test_parts_on_a_line_tell_the_drift_and_its_offset():
    # 100 ppm: 2 ms per 20 s, about 40 s
    line = drift_line(_split([-2.95, -1.02, 1.01, 2.96]), 40.0)
    assert line.tells and line.drift == pytest.approx(98.8e-6, abs=1e-9)
    assert line.offset_s == pytest.approx(0.0, abs=2e-5) and 0 < line.drift_sigma < 5e-6
    assert "drift 98.8 +- 2.2 ppm" in line.note()


@pytest.mark.parametrize("offsets_ms, raised", [
    ([0.0, 0.0, 3.0, 3.0], True),       # a clock that jumps once: not a line
    ([0.0, 3.0, -3.0, 0.5], True),      # a wander
    ([-0.1, 0.0, 0.05, 0.1], False),    # within chance of one offset
])
def test_parts_off_a_line_or_within_chance_tell_no_drift(offsets_ms, raised):
    assert not drift_line(_split(offsets_ms, raised=raised), 40.0).tells


def test_too_few_parts():
    assert drift_line(_split([0.0, 1.0]), 40.0) is None
    three = drift_line(_split([-2.0, 0.0, 2.0]), 30.0)
    assert three is not None and three.n < DRIFT_MIN_PARTS and not three.tells
