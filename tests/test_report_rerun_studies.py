"""Sweep and experiment recordings read back."""

from __future__ import annotations

import numpy as np
import pytest
from rrd_reading import chunks

from simcalib.report.rerun.studies import log_experiment, record_sweep


def test_record_sweep_and_experiment(tmp_path):

    def st(m):
        return {"rot_med": m, "rot_q1": 0.5 * m, "rot_q3": 2 * m, "tr_med": 0.01 * m,
                "tr_q1": 0.005 * m, "tr_q3": 0.02 * m, "failed": 0.0}
    summary = {"per_axis": {"noise.sigma_r_deg": {v: {"dqopt": st(v), "daniilidis": st(3 * v)}
                                                  for v in (0.1, 0.5, 1.0)}}}
    p = record_sweep(tmp_path / "sweep.rrd", summary)
    ents = chunks(p)
    med = ents["/sweep/noise_sigma_r_deg/log10_rotation_deg/dqopt/median"]["Scalars:scalars"]
    np.testing.assert_allclose(np.ravel(med), np.log10([0.1, 0.5, 1.0]))
    assert "/sweep/noise_sigma_r_deg/values" in ents
    with pytest.raises(TypeError, match="summary must be a dict"):
        record_sweep(tmp_path / "bad.rrd", [1, 2])
    from PIL import Image
    png = tmp_path / "f.png"
    Image.new("RGB", (8, 8)).save(png)
    q = log_experiment(tmp_path / "exp.rrd", "table2", {"table2_sweep": png},
                       {"table2": "| a |\n|---|\n| 1 |"})
    ents = chunks(q)
    assert "/figures/table2_sweep" in ents and "/tables/table2" in ents
    from rerun.chunk import RrdReader
    assert RrdReader(str(q)).blueprints() and RrdReader(str(p)).blueprints()
