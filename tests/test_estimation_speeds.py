"""The motion speeds the clock offset correlates (simcalib.estimation.speeds)."""

import numpy as np
import pytest

from simcalib.estimation.speeds import angular_speed, speed_steps, translation_speed
from simcalib.world.stream_sim import rig_streams


def test_angular_speed_is_convention_free():
    from simcalib.geometry import invert_transform
    rs = rig_streams(rng=np.random.default_rng(0))
    _, w = angular_speed(rs.a)
    _, w_inv = angular_speed((rs.t_a, invert_transform(rs.T_a)))
    assert np.allclose(w, w_inv)


def test_speed_steps_and_bad_step():
    t_fast, t_slow = np.arange(0, 10, 1 / 300), np.arange(0, 10, 1 / 30)
    assert speed_steps(t_fast, t_slow) == (10, 1)
    assert speed_steps(t_slow, t_slow) == (1, 1)
    rs = rig_streams(rng=np.random.default_rng(0))
    t_mid, w = angular_speed(rs.a, 3)
    assert w.size == rs.t_a.size - 3 and np.allclose(t_mid, 0.5 * (rs.t_a[:-3] + rs.t_a[3:]))
    assert translation_speed(rs.a, 10 ** 6)[1].size == 1     # capped at the stream's length
    for bad in (0, 1.5, True, "2"):
        with pytest.raises(ValueError, match="step must be an integer"):
            angular_speed(rs.a, bad)


def test_above_noise_tells_motion_from_pose_noise():
    """A stream that stands still with pose noise moves by its noise over any span (~1x
    its pose-to-pose motion); one that moves, ~k times its motion over one sample."""
    from simcalib.estimation.speeds import NOISE_GAIN, above_noise, apart
    from simcalib.world.stream_sim import perturb_transforms
    rng = np.random.default_rng(0)
    still = perturb_transforms(np.tile(np.eye(4), (300, 1, 1)), np.radians(0.5), 0.002, rng)
    rs = rig_streams(rng=np.random.default_rng(1))
    for signal in ("rotation", "translation"):
        assert not above_noise(np.median(apart(still, 30, signal)), still, signal)
        assert above_noise(np.median(apart(rs.T_a, 30, signal)), rs.T_a, signal)
        one = float(np.median(apart(still, 1, signal)))
        assert list(above_noise([NOISE_GAIN * one * 0.99, NOISE_GAIN * one * 1.01], still,
                                signal)) == [False, True]
