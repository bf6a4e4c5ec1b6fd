"""A sweep's directory: one JSON file per finished cell, the merged table and the manifest.

Layout of ``output=DIR``::

    sweep.json            the sweep file as parsed, the cell list (index, key, values, seed)
    cells/<key>.json      one per finished cell (written atomically: temp file + rename)
    runs/<key>/           each cell's run directory (results.json, config.yaml, ...)
    results.parquet       the tidy table: a row per cell x solver (rebuilt from cells/)
    report.md, *.png      the report (``sweep report DIR`` rebuilds it)

Killing a sweep loses at most the cells that were running; a re-run skips every cell whose
``cells/<key>.json`` exists.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any, Iterable

__all__ = ["write_manifest", "read_manifest", "write_cell", "finished_keys", "read_cells",
           "table", "write_table", "MANIFEST"]

MANIFEST = "sweep.json"


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _default(x):
    import numpy as np
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    return str(x)


def write_manifest(out: Path, spec, cells) -> Path:
    import dataclasses
    data = {"schema_version": 1, "spec": dataclasses.asdict(spec),
            "axes": list(spec.axes),
            "cells": [{"index": c.index, "key": c.key, "values": dict(c.values),
                       "replicate": c.replicate, "seed": c.seed} for c in cells]}
    path = Path(out) / MANIFEST
    _atomic_write(path, json.dumps(data, indent=1, default=_default))
    return path


def read_manifest(out: Path) -> dict:
    path = Path(out) / MANIFEST
    if not path.is_file():
        from simcalib.errors import DataError
        raise DataError(f"{out} is not a sweep directory (no {MANIFEST}); run "
                        f"'simcalib sweep FILE output={out}' first")
    return json.loads(path.read_text())


def write_cell(out: Path, record: dict) -> Path:
    path = Path(out) / "cells" / f"{record['key']}.json"
    _atomic_write(path, json.dumps(record, default=_default))
    return path


def finished_keys(out: Path) -> set[str]:
    d = Path(out) / "cells"
    return {p.stem for p in d.glob("*.json")} if d.is_dir() else set()


def read_cells(out: Path, keys: Iterable[str] | None = None) -> dict[str, dict]:
    d = Path(out) / "cells"
    want = None if keys is None else set(keys)
    found = {}
    for p in sorted(d.glob("*.json")) if d.is_dir() else ():
        if want is not None and p.stem not in want:
            continue
        try:
            found[p.stem] = json.loads(p.read_text())
        except json.JSONDecodeError:  # a file cut by a crash outside the atomic rename
            continue
    return found


def table(out: Path) -> list[dict[str, Any]]:
    """The tidy rows (cell x solver) of the finished cells, in cell order. A failed cell
    gives one row with ``status='failed'`` and its error."""
    manifest = read_manifest(out)
    cells = read_cells(out)
    axes = manifest["axes"]
    rows = []
    for c in manifest["cells"]:
        rec = cells.get(c["key"])
        if rec is None:
            continue
        base = {"cell": c["index"], "key": c["key"], "replicate": c["replicate"],
                "seed": c["seed"], "status": rec["status"], "cell_s": rec.get("cell_s"),
                "run_s": rec.get("run_s")}
        base.update({a: _scalar(c["values"].get(a)) for a in axes})
        if rec["status"] != "ok" or not rec["rows"]:
            err = rec.get("error") or {}
            rows.append({**base, "solver": None,
                         "cell_error": f"{err.get('type', '')}: {err.get('message', '')}"
                         if err else None})
            continue
        for r in rec["rows"]:
            rows.append({**base, **r, "cell_error": None})
    return rows


def _scalar(v):
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v)
    return v


def write_table(out: Path) -> Path:
    """``results.parquet`` from the finished cells (columns: the swept keys, seed, solver,
    errors, success, verdict, runtime, frames used/dropped, pose-source error)."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    rows = table(out)
    columns: dict[str, list] = {}
    for r in rows:
        for k in r:
            columns.setdefault(k, [])
    for r in rows:
        for k in columns:
            columns[k].append(r.get(k))
    arrays = {}
    for k, vals in columns.items():
        try:
            arrays[k] = pa.array(vals)
        except (pa.ArrowInvalid, pa.ArrowTypeError):  # mixed types: keep them as text
            arrays[k] = pa.array([None if v is None else str(v) for v in vals])
    path = Path(out) / "results.parquet"
    tmp = path.with_suffix(".parquet.tmp")
    pq.write_table(pa.table(arrays) if arrays else pa.table({}), tmp)
    os.replace(tmp, path)
    return path


def status(output: str | Path) -> dict[str, Any]:
    """What is done in a sweep directory: cells total / done / failed / remaining."""
    manifest = read_manifest(output)
    cells = read_cells(output)
    keys = [c["key"] for c in manifest["cells"]]
    done = [k for k in keys if k in cells]
    failed = [k for k in done if cells[k]["status"] != "ok"]
    run_s = [cells[k].get("cell_s") or 0.0 for k in done]
    return {"output": str(output), "cells": len(keys), "done": len(done),
            "failed": len(failed), "remaining": len(keys) - len(done),
            "cell_s_mean": (sum(run_s) / len(run_s)) if run_s else None,
            "failed_cells": [{"index": c["index"], "key": c["key"],
                              "error": cells[c["key"]].get("error")}
                             for c in manifest["cells"] if c["key"] in failed][:20]}
