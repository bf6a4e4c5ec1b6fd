"""Resolving and running one cell of a sweep (the function every executor runs).

:func:`resolve_cells` validates every cell's configuration with the one config engine
before any work and keys each cell by its resolved configuration; :func:`run_cell` runs one
cell in a worker and returns a plain dict (its swept values, status, rows — one per solver —
and timings) that :mod:`simcalib.studies.sweep.store` writes as ``cells/<key>.json``.
"""

from __future__ import annotations

import dataclasses
import time
import traceback
from pathlib import Path
from typing import Any, Mapping

from simcalib.studies.sweep.spec import Cell, SweepSpec, cell_key

__all__ = ["check_keys", "resolve_cells", "run_cell", "rows_from_results", "ROW_FIELDS"]

#: scalar fields copied from a solver entry of results.json into a table row
ROW_FIELDS = ("alpha", "rotation_error_deg", "translation_error_m",
              "translation_error_determined_m", "cost", "runtime_s", "success", "degenerate",
              "error")


def _base_of(spec: SweepSpec, cell: Cell) -> tuple[str, dict]:
    overrides = dict(cell.overrides)
    base = str(overrides.pop("scenario", spec.base))
    return base, overrides


def check_keys(spec: SweepSpec) -> None:
    """Every run key the sweep sets or sweeps is a key of the run configuration: an unknown
    one is reported once (with the closest match and where it was given), before any cell
    is built or run."""
    from simcalib.pipeline.scenario import ScenarioConfig, resolve_keys
    from simcalib.errors import ConfigError
    blocks = (("set", spec.set), ("grid", spec.grid), ("zip", spec.zip),
              ("random.keys", spec.random))
    for block, keys in blocks:
        for key in keys:
            if key == "scenario":   # the base of the cell, not a run key
                continue
            try:
                resolve_keys(ScenarioConfig, str(key))
            except ConfigError as exc:
                where = ("on the command line or under 'set'" if block == "set"
                         else f"under '{block}'")
                raise ConfigError(f"sweep {spec.name}: {exc} (given {where}; no cell was "
                                  f"run)", key=str(key)) from None


def resolve_cells(spec: SweepSpec, cells: list[Cell], *, output: Path,
                  recording: bool = False) -> list[tuple[Cell, Any]]:
    """``(cell with its key, validated ScenarioConfig)`` for every cell. All cells are
    checked before any work; one ConfigError lists the failing cells. Cell outputs go to
    ``output/runs/<key>``; recordings are off unless ``recording``."""
    from simcalib.pipeline.scenario import load_configs
    from simcalib.config.engine import to_dict
    check_keys(spec)
    groups: dict[str, list[int]] = {}
    per_cell = []
    for i, cell in enumerate(cells):
        base, ov = _base_of(spec, cell)
        ov.setdefault("progress", False)
        ov.setdefault("recording.enabled", recording)
        ov.setdefault("workers", 1)
        ov.setdefault("overwrite", True)   # a cell re-run (failed, or recorded) replaces it
        per_cell.append(ov)
        groups.setdefault(base, []).append(i)
    configs: list[Any] = [None] * len(cells)
    for base, idx in groups.items():
        for i, cfg in zip(idx, load_configs(base, [per_cell[i] for i in idx])):
            configs[i] = cfg
    out = []
    for cell, cfg in zip(cells, configs):
        key = cell_key(to_dict(cfg))
        cfg = dataclasses.replace(cfg, output=str(Path(output) / "runs" / key))
        out.append((dataclasses.replace(cell, key=key), cfg))
    return out


def rows_from_results(results: Mapping) -> list[dict]:
    """One row per solver of a run's results.json (plain scalars)."""
    rows = []
    frames = results.get("frames") or {}
    pose = results.get("pose_error") or {}
    common: dict[str, Any] = {"frames_rendered": frames.get("rendered")}
    for cam in ("cam_a", "cam_b"):
        f = frames.get(cam) or {}
        common[f"{cam}_used"] = f.get("used")
        common[f"{cam}_dropped"] = f.get("dropped")
        pe = pose.get(cam) or {}
        common[f"{cam}_pose_rotation_median_deg"] = (pe.get("rotation_deg") or {}).get("median")
        common[f"{cam}_pose_translation_median_m"] = (pe.get("translation_m") or {}).get(
            "median")
    common["motions_used"] = (results.get("pairing") or {}).get("used")
    for label, s in (results.get("solvers") or {}).items():
        row = {"solver": label, "method": s.get("method")}
        row.update({f: s.get(f) for f in ROW_FIELDS})
        # predicted uncertainty and verdict (results.json)
        row["sigma_rotation_deg"] = s.get("sigma_rotation_deg")
        row["sigma_translation_m"] = s.get("sigma_translation_m")
        verdict = s.get("verdict")
        row["verdict"] = verdict.get("verdict") if isinstance(verdict, dict) else verdict
        oracle = s.get("oracle_alpha") or {}
        row["oracle_alpha"] = oracle.get("alpha") if isinstance(oracle, dict) else None
        row.update(common)
        rows.append(row)
    return rows


def run_cell(cell: Cell, config) -> dict:
    """Run one cell (in a worker): never raises for a failing run — the failure is
    recorded with its type and message."""
    import json
    t0 = time.perf_counter()
    record: dict[str, Any] = {"key": cell.key, "index": cell.index,
                              "values": dict(cell.values), "replicate": cell.replicate,
                              "seed": cell.seed, "status": "ok", "error": None, "rows": []}
    try:
        from simcalib.pipeline.stages import run
        t_run = time.perf_counter()
        result = run(config, echo=False)
        record["run_s"] = time.perf_counter() - t_run
        path = result.results_path or Path(config.output) / "results.json"
        results = json.loads(Path(path).read_text())
        record["rows"] = rows_from_results(results)
        record["timing_s"] = results.get("timing_s")
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - one failing cell never sinks the sweep
        record["status"] = "failed"
        record["error"] = {"type": type(exc).__name__,
                           "message": str(exc).strip().splitlines()[0] if str(exc).strip()
                           else type(exc).__name__,
                           "where": traceback.format_exc(limit=-1).strip().splitlines()[-3:]}
    record["cell_s"] = time.perf_counter() - t0
    return record
