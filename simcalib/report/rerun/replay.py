"""The recording worker: a separate process that imports rerun and replays the calls a
recording made through the stand-ins of :mod:`simcalib.report.rerun.worker` (a run's
:class:`~simcalib.report.rerun.run.RunRecorder`, a calibration's recording), so that
importing rerun (0.4-1 s) and writing the file overlap the work instead of adding to it.

Run as a script (``python -P simcalib/report/rerun/replay.py SPOOL STATUS_JSON PARENT_PID``; no
simcalib import, only numpy and rerun). It follows the spool file SPOOL, which the run
appends length-prefixed pickles to (appending to a file never blocks the run, unlike a
full pipe while the worker still imports rerun):

* ``("init", kwargs_of_RecordingStream, save_path)``
* ``("rec", method, args, kwargs)`` — ``getattr(recording, method)(*args, **kwargs)``
* ``("close",)`` — flush, disconnect, write STATUS_JSON and exit

Arguments may hold encoded rerun objects (:func:`decode`): ``(_TAG, "ref", path)`` is the
attribute ``rerun.<path>`` (``("blueprint", "Vertical")`` -> ``rerun.blueprint.Vertical``),
``(_TAG, "new", path, args, kwargs)`` its call, ``(_TAG, "meth", obj, name, args, kwargs)``
a method call on a decoded object. SIGINT is ignored (a Ctrl-C of the run closes the
recording through the run loop, which sends ``close``); when the run's process is gone
without sending it, the worker closes the recording with what it received.
STATUS_JSON gets ``{"import_s", "log_s", "calls", "errors"}``; errors also go to stderr.
The worker then ends at once (:func:`simcalib.parallel.exit_now`: rerun's exit handler
runs, the interpreter's teardown of rerun, pyarrow and numpy, 0.1-0.3 s that the run would
wait for, does not).
"""

from __future__ import annotations

import json
import pickle
import signal
import struct
import sys
import time
import traceback

_TAG = "\x00simcalib-rr"
_HEADER = struct.Struct("<Q")
#: the longest wait between two looks at the spool: the run's last calls (a calibration
#: logs everything at its end) wait for it (a look costs a few microseconds)
NAP_MAX_S = 0.01


def decode(x, rr):
    """Rebuild the rerun objects encoded in ``x`` (nested tuples, lists, dicts)."""
    if isinstance(x, tuple):
        if len(x) >= 2 and x[0] == _TAG:
            kind = x[1]
            if kind == "ref":
                obj = rr
                for name in x[2]:
                    obj = getattr(obj, name)
                return obj
            if kind == "new":
                fn = decode((_TAG, "ref", x[2]), rr)
                return fn(*decode(x[3], rr), **decode(x[4], rr))
            if kind == "meth":
                obj = decode(x[2], rr)
                return getattr(obj, x[3])(*decode(x[4], rr), **decode(x[5], rr))
            raise ValueError(f"unknown encoded rerun object {kind!r}")
        return tuple(decode(v, rr) for v in x)
    if isinstance(x, list):
        return [decode(v, rr) for v in x]
    if isinstance(x, dict):
        return {k: decode(v, rr) for k, v in x.items()}
    return x


def _read(spool, parent_pid: int):
    """The next message of the spool (waiting for the run to append it), or None when the
    run's process ended without closing."""
    import os
    buf = b""
    need = _HEADER.size
    header_done = False
    nap = 0.002   # waits grow to NAP_MAX_S while the run appends nothing (a stage computing)
    while True:
        chunk = spool.read(need - len(buf))
        if chunk:
            buf += chunk
            nap = 0.002
        if len(buf) == need:
            if header_done:
                return pickle.loads(buf)
            (need,) = _HEADER.unpack(buf)
            buf, header_done = b"", True
            continue
        if not chunk:
            if os.getppid() != parent_pid:
                return None
            time.sleep(nap)
            nap = min(NAP_MAX_S, 1.5 * nap)


def main(argv) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    spool_path, status_path, parent_pid = argv[1], argv[2], int(argv[3])
    t0 = time.perf_counter()
    import rerun as rr
    import rerun.blueprint
    import_s = time.perf_counter() - t0
    spool = open(spool_path, "rb", buffering=0)
    rec = None
    calls, errors, log_s = 0, [], 0.0
    while True:
        msg = _read(spool, parent_pid)
        if msg is None or msg[0] == "close":
            break
        t1 = time.perf_counter()
        try:
            if msg[0] == "init":
                rec = rr.RecordingStream(**msg[1])
                if hasattr(rec, "set_log_time_enabled"):
                    rec.set_log_time_enabled(False)
                rec.save(msg[2])
            elif msg[0] == "rec":
                _, method, args, kwargs = msg
                getattr(rec, method)(*decode(args, rr), **decode(kwargs, rr))
                calls += 1
            else:
                raise ValueError(f"unknown message {msg[0]!r}")
        except Exception:   # keep recording the rest; the run reports it at close
            err = traceback.format_exc()
            errors.append(err)
            print(err, file=sys.stderr, flush=True)
        log_s += time.perf_counter() - t1
    t1 = time.perf_counter()
    if rec is not None:
        try:
            rec.flush()
        finally:
            rec.disconnect()
    log_s += time.perf_counter() - t1
    spool.close()
    if status_path:
        with open(status_path, "w") as f:
            json.dump({"import_s": import_s, "log_s": log_s, "calls": calls,
                       "errors": errors}, f)
    return 1 if errors else 0


if __name__ == "__main__":
    from simcalib.parallel import exit_now
    exit_now(main(sys.argv))
