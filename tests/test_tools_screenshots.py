"""simcalib.tools.screenshots helpers that need no viewer (the screenshot checks themselves
run in tests/test_report_rerun_*.py)."""

from __future__ import annotations

import subprocess
from types import SimpleNamespace

import numpy as np


def test_ocr_runs_tesseract_on_one_thread(tmp_path, monkeypatch):
    """tesseract's OpenMP threads read the same text for ~3x the CPU time (their waiting):
    every OCR call runs it with OMP_THREAD_LIMIT=1, whatever the caller's environment."""
    from PIL import Image

    from simcalib.tools import screenshots
    png = tmp_path / "shot.png"
    Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(png)
    calls = []

    def run(cmd, **kw):
        calls.append((cmd, kw))
        return SimpleNamespace(stdout="text", returncode=0)

    monkeypatch.setenv("OMP_THREAD_LIMIT", "4")
    monkeypatch.setattr(subprocess, "run", run)
    for bright in (False, True):
        assert screenshots.ocr_text(png, bright_text=bright) == "text"
    assert [c[0][0] for c in calls] == ["tesseract", "tesseract"]
    assert all(kw["env"]["OMP_THREAD_LIMIT"] == "1" for _, kw in calls)
