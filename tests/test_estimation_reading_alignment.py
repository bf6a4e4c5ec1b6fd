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
