"""The recording worker's client: the process logging a recording never imports rerun
(0.4-1 s); it logs through stand-ins (:class:`RRProxy`) whose calls are pickled into a
spool file that a worker process (:mod:`simcalib.report.rerun.replay`) replays with the
real rerun, so importing rerun and writing the file happen beside the work.

:func:`open_stream` gives any recording ``(rec, rr)``: a :class:`WorkerStream` and the
stand-in for ``rerun``, or (``background=False``, or no process can be started) a real
:class:`rerun.RecordingStream` and the real module; :func:`finish_stream` closes either.
``simcalib run`` and ``simcalib calibrate`` start the worker before they even load their
input (:func:`prestart_worker`); the next :func:`open_stream` adopts it.
"""

from __future__ import annotations

import sys
from pathlib import Path

from simcalib.report.rerun.replay import _HEADER, _TAG  # the wire format (stdlib only)

__all__ = ["RRProxy", "WorkerStream", "prestart_worker", "cancel_prestarted_worker",
           "worker_stream", "open_stream", "finish_stream", "worker_pays_off", "encode"]


class RRProxy:
    """Stands for ``rerun`` (or one of its attributes) in the run's process: attribute
    access and calls build the encoded objects :mod:`simcalib.report.rerun.replay` rebuilds in
    the recording worker. Children are cached, so ``rrb.Vertical is rrb.Vertical``."""

    def __init__(self, path=()):
        self._path = tuple(path)
        self._children: dict[str, RRProxy] = {}

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        child = self._children.get(name)
        if child is None:
            child = self._children[name] = RRProxy(self._path + (name,))
        return child

    def __call__(self, *args, **kwargs):
        return RRObject((_TAG, "new", self._path, encode(args), encode(kwargs)))

    def _encoded(self):
        return (_TAG, "ref", self._path)


class RRObject:
    """A rerun object built in the worker (``rr.Image(x)``); method calls chain
    (``.compress(jpeg_quality=70)``)."""

    def __init__(self, spec):
        self._spec = spec

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return lambda *args, **kwargs: RRObject(
            (_TAG, "meth", self._spec, name, encode(args), encode(kwargs)))

    def _encoded(self):
        return self._spec


_NESTED = (RRProxy, RRObject, tuple, list, dict)


def encode(x):
    """``x`` with the stand-ins replaced by their encodings (containers of plain values,
    e.g. colours or vertex lists, are passed through as they are)."""
    if isinstance(x, (RRProxy, RRObject)):
        return x._encoded()
    if isinstance(x, (tuple, list)):
        if not any(isinstance(v, _NESTED) for v in x):
            return x
        return type(x)(encode(v) for v in x)
    if isinstance(x, dict):
        return {k: encode(v) for k, v in x.items()}
    return x


class WorkerStream:
    """A :class:`rerun.RecordingStream` living in the recording worker process
    (:mod:`simcalib.report.rerun.replay`): every method call is pickled and appended to a spool
    file the worker follows (appending never blocks the run, also while the worker still
    imports rerun; no thread). :meth:`finish` closes the stream and waits for the file;
    it raises when the worker reported an error."""

    def __init__(self, path: Path | None = None, **stream_kwargs):
        """Start the worker; with ``path``, open the recording there (else :meth:`open`
        does later: a worker started before the run is known, :func:`prestart_worker`)."""
        import os
        import subprocess
        import tempfile
        script = Path(__file__).with_name("replay.py")
        fd, spool = tempfile.mkstemp(prefix="simcalib-rec-", suffix=".spool")
        self._spool_path = Path(spool)
        self._spool = os.fdopen(fd, "wb", buffering=1 << 20)   # handed over per stage
        self._status = self._spool_path.with_suffix(".json")
        self._stderr = tempfile.TemporaryFile()
        self._proc = subprocess.Popen(
            [sys.executable, "-P", str(script), str(self._spool_path), str(self._status),
             str(os.getpid())], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=self._stderr)
        self.status: dict = {}
        if path is not None:
            self.open(path, **stream_kwargs)

    def open(self, path: Path, **stream_kwargs) -> None:
        self._send(("init", stream_kwargs, str(path)))
        self.handoff()

    def alive(self) -> bool:
        return self._proc.poll() is None and not self._spool.closed

    def cancel(self) -> None:
        """Stop an unused worker (no recording written)."""
        if not self._spool.closed:
            self._spool.close()
        if self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        self._stderr.close()
        for p in (self._spool_path, self._status):
            p.unlink(missing_ok=True)

    def _send(self, msg):
        import pickle
        data = pickle.dumps(msg, protocol=pickle.HIGHEST_PROTOCOL)
        self._spool.write(_HEADER.pack(len(data)))
        self._spool.write(data)

    def handoff(self) -> None:
        """Make what was logged so far visible to the worker (after each stage)."""
        self._spool.flush()

    def __getattr__(self, method):
        if method.startswith("_"):
            raise AttributeError(method)
        return lambda *args, **kwargs: self._send(("rec", method, encode(args),
                                                   encode(kwargs)))

    def finish(self) -> None:
        """Close the recording, wait for the worker to write it, report its errors."""
        import json
        try:
            self._send(("close",))
            self._spool.close()
            code = self._proc.wait()
        finally:
            if self._proc.poll() is None:   # interrupted while waiting
                self._proc.kill()
                self._proc.wait()
            self._spool_path.unlink(missing_ok=True)
        try:
            self.status = json.loads(self._status.read_text() or "{}")
        except (OSError, ValueError):
            self.status = {}
        finally:
            self._status.unlink(missing_ok=True)
        self._stderr.seek(0)
        err = self._stderr.read().decode(errors="replace").strip()
        self._stderr.close()
        if code != 0:
            raise RuntimeError(f"the recording worker failed (exit {code}): "
                               + "\n".join(err.splitlines()[-12:]))
        if err:   # rerun's warnings, as they would have appeared in-process
            print(err, file=sys.stderr)


_PRESTARTED: list = []       # a worker started ahead of the run (prestart_worker)


def prestart_worker() -> None:
    """Start the recording worker now, before the run's configuration is even loaded, so
    that rerun's import overlaps that too; the next :func:`open_stream` adopts it (an
    unused one is stopped at exit). Used by ``simcalib run`` and ``simcalib calibrate``."""
    if _PRESTARTED or "rerun" in sys.modules:   # imported already: nothing to hide
        return
    try:
        w = WorkerStream()
    except OSError:   # no worker: the recorder starts one, or logs in-process
        return
    _PRESTARTED.append(w)
    import atexit
    atexit.register(cancel_prestarted_worker)


def cancel_prestarted_worker() -> None:
    """Stop a worker :func:`prestart_worker` started when the run records nothing."""
    while _PRESTARTED:
        _PRESTARTED.pop().cancel()


def worker_stream(path: Path, **stream_kwargs) -> WorkerStream:
    while _PRESTARTED:
        w = _PRESTARTED.pop()
        if w.alive():
            w.open(path, **stream_kwargs)
            return w
        w.cancel()
    return WorkerStream(path, **stream_kwargs)


def open_stream(path, background: bool = True, **stream_kwargs):
    """``(rec, rr, background)``: a recording stream saving to ``path`` and ``rerun`` (or
    the stand-in for it). ``background``: through the recording worker (a prestarted one
    is adopted) unless no process can be started here; else in-process (an unused
    prestarted worker is stopped). ``stream_kwargs``: of :class:`rerun.RecordingStream`
    (``application_id``, ``recording_id``, ...). Whether a worker pays off is the
    caller's call (:func:`worker_pays_off`)."""
    path = Path(path)
    if background:
        try:
            return worker_stream(path, **stream_kwargs), RRProxy(), True
        except OSError:   # no process can be started here: log in-process
            pass
    cancel_prestarted_worker()
    import rerun as rr
    rec = rr.RecordingStream(**stream_kwargs)
    rec.set_log_time_enabled(False)
    rec.save(str(path))
    return rec, rr, False


def worker_pays_off() -> bool:
    """A worker hides rerun's import only when this process has not imported it yet (a
    test session or a notebook has: there logging in-process costs nothing more)."""
    return "rerun" not in sys.modules


def finish_stream(rec, background: bool) -> None:
    """Close a stream of :func:`open_stream`: wait for the worker to write the file (its
    errors raised) or flush and disconnect."""
    if background:
        rec.finish()
    else:
        rec.flush()
        rec.disconnect()
