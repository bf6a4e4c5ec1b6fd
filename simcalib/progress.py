"""Progress for people: a bar on a terminal, throttled lines in logs and pipes, and the
frames of the run stage in progress (:func:`frame_progress`, for the stages that render)."""

from __future__ import annotations

import contextlib
import contextvars
import sys
from typing import Iterable

__all__ = ["progress", "progress_line", "stage_frames", "frame_progress"]

def progress(iterable: Iterable | None = None, *, enabled: bool = True, **kw):
    """A tqdm progress bar on stderr; off when disabled or when stderr is not a terminal
    (so logs and pipes stay clean)."""
    from tqdm.auto import tqdm
    return tqdm(iterable, disable=None if enabled else True, file=sys.stderr,
                dynamic_ncols=True,
                leave=False, **kw)


def progress_line(text: str, *, enabled: bool = True) -> None:
    """One progress line on stderr where :func:`progress` shows no bar (stderr is not a
    terminal: logs, CI, pipes), so a long run still says where it is."""
    if enabled and not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        print(f"[simcalib] {text}", file=sys.stderr, flush=True)


_FRAME_PROGRESS: contextvars.ContextVar = contextvars.ContextVar("simcalib_frame_progress",
                                                                default=None)


def frame_progress():
    """The ``(n_done, n_total)`` frame callback of the run stage in progress (set by
    :func:`stage_frames`), or None outside a run or with progress off."""
    return _FRAME_PROGRESS.get()


class _StageFrames:
    """Frames done within one stage: moves the stage bar by the stage's share (a tty) or
    prints a line per tenth of the frames (logs, pipes) — never one line per frame."""

    def __init__(self, bar, stage: str, n_before: int, enabled: bool):
        self.bar, self.stage, self.n_before, self.enabled = bar, stage, n_before, enabled
        self._tenth = 0

    def __call__(self, n_done: int, n_total: int) -> None:
        if n_total <= 0:
            return
        frac = min(max(n_done / n_total, 0.0), 1.0)
        if not getattr(self.bar, "disable", True):
            self.bar.n = self.n_before + frac
            self.bar.set_postfix_str(f"frames {n_done}/{n_total}", refresh=True)
        tenth = int(10 * frac)
        if tenth > self._tenth:
            self._tenth = tenth
            progress_line(f"{self.stage}: frames {n_done}/{n_total} ({100 * frac:.0f} %)",
                          enabled=self.enabled)


@contextlib.contextmanager
def stage_frames(bar, stage: str, n_before: int, *, enabled: bool = True):
    """While the block runs, :func:`frame_progress` reports frames of ``stage`` (the
    ``n_before``-th stage) on ``bar`` and, off a terminal, as throttled lines."""
    token = _FRAME_PROGRESS.set(_StageFrames(bar, stage, n_before, enabled) if enabled
                                else None)
    try:
        yield
    finally:
        _FRAME_PROGRESS.reset(token)
        if not getattr(bar, "disable", True):
            bar.n = n_before
            bar.set_postfix_str("", refresh=False)
