"""The recording worker: a recording written by the worker process equals one logged
in-process; its errors surface at close; a prestarted worker is adopted or stopped."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from rrd_reading import chunks, solver_stub

import simcalib.report.rerun.worker as W
from simcalib.report.rerun.run import RunRecorder


def test_worker_and_in_process_recordings_match(tmp_path):
    """The recording worker (rerun imported and the file written in another process)
    writes what logging in-process writes; its errors surface at close."""
    cfg = SimpleNamespace(kind="synthetic", recording=SimpleNamespace(max_images=0,
                                                                      jpeg_quality=70))
    X = np.eye(4)
    X[:3, 3] = [0.0, 0.2, 0.0]
    cov = np.diag([1e-6, 1e-6, 1e-6, 4e-4, 1e-4, 1e-4])
    got = {}
    for background in (True, False):
        rec = RunRecorder(tmp_path / f"{background}.rrd", cfg, background=background)
        assert rec.background is background
        rec.log_estimates([solver_stub("good", X, cov=cov), solver_stub("broken", None)], X)
        rec.log_summary("**hello**")
        rec.close()
        got[background] = chunks(tmp_path / f"{background}.rrd")
        view = json.loads((tmp_path / "recording_view.json").read_text())
        assert (view["worker"] is not None) is background
    assert set(got[True]) == set(got[False])
    for ent in ("/closeup/labels/0", "/closeup/uncertainty/good", "/summary"):
        assert got[True][ent] == got[False][ent]
    from rerun.chunk import RrdReader
    assert RrdReader(str(tmp_path / "True.rrd")).blueprints()
    bad = RunRecorder(tmp_path / "bad.rrd", cfg, background=True)
    bad.rec.log("x", bad.rr.NoSuchArchetype([1.0]))
    with pytest.raises(RuntimeError, match="(?s)recording worker failed.*NoSuchArchetype"):
        bad.close()


def test_prestarted_worker_is_adopted_or_stopped(tmp_path):
    W.cancel_prestarted_worker()
    W._PRESTARTED.append(W.WorkerStream())       # what prestart_worker() does
    w = W._PRESTARTED[0]
    cfg = SimpleNamespace(kind="synthetic", recording=SimpleNamespace(max_images=0,
                                                                      jpeg_quality=70))
    rec = RunRecorder(tmp_path / "r.rrd", cfg, background=True)
    assert rec.rec is w and not W._PRESTARTED
    rec.close()
    assert "/closeup" in chunks(tmp_path / "r.rrd")
    W._PRESTARTED.append(W.WorkerStream())
    w = W._PRESTARTED[0]
    W.cancel_prestarted_worker()
    assert w._proc.poll() is not None and not w._spool_path.exists() and not W._PRESTARTED
