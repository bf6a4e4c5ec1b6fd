"""Running a sweep: validate every cell, skip finished ones, run the rest on an executor,
write each cell as it finishes, then the table and the report.

``run_sweep(spec, output, executor="local", workers=None)`` is the library entry point;
``simcalib sweep`` (simcalib/commands/sweep.py) is a thin command over it.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from simcalib.studies.sweep import store
from simcalib.studies.sweep.cells import resolve_cells, run_cell
from simcalib.studies.sweep.spec import SweepSpec, expand

__all__ = ["SweepSummary", "run_sweep", "SweepProgress"]


@dataclass(frozen=True)
class SweepSummary:
    output: Path
    cells: int
    skipped: int            # finished before this call (resumed)
    ran: int
    failed: int
    wall_s: float
    cell_s_total: float     # sum of the cells' own run times (in the workers)
    executor: str
    workers: int | None

    @property
    def overhead_fraction(self) -> float | None:
        """Share of the workers' wall time not spent inside the cells' runs (scheduling,
        process start, pickling, writing): 1 - sum(cell time) / (wall x workers)."""
        if not self.ran or not self.workers or self.wall_s <= 0:
            return None
        return max(0.0, 1.0 - self.cell_s_total / (self.wall_s * min(self.workers,
                                                                      self.ran)))


class SweepProgress:
    """Cells done / failed / ETA: a bar on a terminal, else a line every ``every`` cells."""

    def __init__(self, total: int, enabled: bool = True, every: int = 10, stream=None):
        self.total, self.every = total, max(1, int(every))
        self.stream = stream or sys.stderr
        self.done = self.failed = 0
        self.t0 = time.perf_counter()
        self.enabled = enabled and total > 0
        self.bar = None
        if self.enabled and getattr(self.stream, "isatty", lambda: False)():
            from tqdm.auto import tqdm
            self.bar = tqdm(total=total, file=self.stream, desc="cells", unit="cell",
                            dynamic_ncols=True, leave=False)

    def eta_s(self) -> float | None:
        if not self.done:
            return None
        rate = self.done / (time.perf_counter() - self.t0)
        return (self.total - self.done) / rate if rate > 0 else None

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix(failed=self.failed)
        elif self.done % self.every == 0 or self.done == self.total:
            eta = self.eta_s()
            print(f"sweep: {self.done}/{self.total} cells done, {self.failed} failed"
                  + (f", ETA {eta:.0f} s" if eta is not None else ""),
                  file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_sweep(spec: SweepSpec, output: str | Path, *, executor: str = "local",
              workers: int | None = None, address: str | None = None,
              progress: bool = True, progress_every: int = 10, report: bool = True
              ) -> SweepSummary:
    """Run every unfinished cell of ``spec`` into ``output`` and write the table (and the
    report). All cells are validated before any work. Cells keep going when one fails."""
    from simcalib.executors import get as get_executor
    from simcalib.config.checks import check_int
    out = Path(output)
    if workers is not None:
        workers = check_int("workers", workers, lo=1)
    cells = expand(spec)
    resolved = resolve_cells(spec, cells, output=out)
    ex = get_executor(executor, **({"address": address} if executor == "ray" else {}))
    from simcalib.config.files import output_folder
    output_folder(out)
    store.write_manifest(out, spec, [c for c, _ in resolved])
    finished = store.finished_keys(out)
    todo = [(c, cfg) for c, cfg in resolved if c.key not in finished]
    skipped = len(resolved) - len(todo)
    bar = SweepProgress(len(todo), enabled=progress, every=progress_every)
    t0 = time.perf_counter()
    cell_s = 0.0
    try:
        for i, result in ex.map(run_cell, todo, workers):
            cell, _ = todo[i]
            if isinstance(result, BaseException):
                result = {"key": cell.key, "index": cell.index, "values": dict(cell.values),
                          "replicate": cell.replicate, "seed": cell.seed, "status": "failed",
                          "rows": [], "error": {"type": type(result).__name__,
                                                "message": str(result).splitlines()[0]
                                                if str(result) else ""}}
            store.write_cell(out, result)
            cell_s += float(result.get("cell_s") or 0.0)
            bar.update(result["status"] == "ok")
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    _keep_recordings(spec, out, resolved)
    if report:
        from simcalib.studies.sweep.report import write_report
        store.write_table(out)
        write_report(out)
    return SweepSummary(output=out, cells=len(resolved), skipped=skipped, ran=len(todo),
                        failed=bar.failed, wall_s=wall, cell_s_total=cell_s,
                        executor=executor, workers=workers)


def _keep_recordings(spec: SweepSpec, out: Path, resolved) -> None:
    """Re-run the named cells and the ``record_worst`` worst ones with the recording on
    (same config and seed, so the same numbers) — recordings are off in sweeps."""
    if not spec.record_cells and not spec.record_worst:
        return
    want = {c.key for c, _ in resolved if c.index in set(spec.record_cells)}
    if spec.record_worst:
        scores = []
        for key, rec in store.read_cells(out).items():
            errs = [r.get("rotation_error_deg") for r in rec.get("rows", [])
                    if r.get("rotation_error_deg") is not None]
            scores.append((max(errs) if errs else float("inf"), key))
        want |= {k for _, k in sorted(scores, reverse=True)[:spec.record_worst]}
    from simcalib.pipeline.stages import run
    for cell, cfg in resolved:
        if cell.key in want and not (Path(cfg.output) / "recording.rrd").exists():
            rec_cfg = dataclasses.replace(
                cfg, recording=dataclasses.replace(cfg.recording, enabled=True))
            run(rec_cfg, echo=False)
