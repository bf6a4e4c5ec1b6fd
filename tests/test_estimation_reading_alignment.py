"""The reading and the clock offset decided together (simcalib.estimation.reading_alignment):
streams in other length units are aligned at one scale, then refused or rescaled."""

import numpy as np
import pytest

from simcalib.errors import DataError
from simcalib.estimation.path import calibrate_streams
from simcalib.estimation.scale import scaled_stream
from simcalib.geometry import rotation_error_rad
from simcalib.studies.experiments.recording_kinds import generate


@pytest.mark.slow
@pytest.mark.parametrize("seed,unit", [(0, 1e3), (1, 1e-3), (0, 100.0)])
def test_a_continuous_stream_in_other_units_is_refused_not_misaligned(seed, unit):
    """b in mm (or a in mm, or b in cm) against a in m, continuous motion: the readings'
    scores and the offset's cost add both streams' translations, so b at 1000x a's scale
    once pulled the first reading's offset to 13.9 s and X 102 deg off with the reading
    merely "not clear"; now the offset and reading are decided at a's scale and the units
    refused (scale_b=auto), or b rescaled (scale_b=estimate) to the X of the metric files."""
    rec = generate("continuous", seed)
    b = scaled_stream(rec.stream_b, unit)
    with pytest.raises(DataError, match="different units"):
        calibrate_streams(rec.stream_a, b)
    r = calibrate_streams(rec.stream_a, b, scale_b="estimate")
    want = calibrate_streams(rec.stream_a, rec.stream_b).X
    assert np.degrees(rotation_error_rad(r.X, want)) < 0.01
    assert np.linalg.norm(r.X[:3, 3] - want[:3, 3]) < 5e-4
    assert abs(r.time_offset.offset_s - rec.offset_s) < 3e-3


@pytest.mark.parametrize("mirror", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_handedness_is_checked_at_the_final_offset_where_it_moved(mirror):
    """Stop-and-go with b on another clock (25.5 s early): the first decision's offset
    (the speeds' correlation's, -55.8 s) pairs no motions right, and b's handedness was
    'not told' there (ratio 1.03 as written, 0.95 mirrored); at the stop-placed final
    offset the data tell it: b as written is taken so (its pitches follow a's), a
    mirrored b is read mirrored and X is the true one."""
    from simcalib.estimation.path import align_and_read
    from simcalib.estimation.readings import MIRROR_RATIO
    from simcalib.estimation.sampling import classify_sampling
    from simcalib.tools.mirror_margin import mirrored_file
    rec = generate("stop_and_go_two_clocks", 0)
    a, b = rec.stream_a, mirrored_file(rec.stream_b) if mirror else rec.stream_b
    *_, conv, off, _ = align_and_read(a, b, classify_sampling(a, b), seed=0)
    assert off.at_stops and abs(off.offset_s - rec.offset_s) < 0.5, off.message
    assert conv.mirror_told and conv.mirror_X is None, conv.message
    assert "not told" not in conv.message
    assert conv.mirror_b == mirror
    if mirror:
        assert conv.mirror_ratio > MIRROR_RATIO and "MIRRORED" in conv.message
        r = calibrate_streams(a, b, seed=0)
        assert np.degrees(rotation_error_rad(r.X, rec.X_true)) < 0.1
        assert np.linalg.norm(r.X[:3, 3] - rec.X_true[:3, 3]) < 2e-3
