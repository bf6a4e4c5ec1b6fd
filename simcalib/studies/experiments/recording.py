"""The experiments' recordings: an experiment's PNG figures and markdown tables in
``<output>/<name>.rrd`` (headless, no viewer), written by
:func:`simcalib.report.rerun.studies.log_experiment`."""

from __future__ import annotations

from pathlib import Path

__all__ = ["log_experiment"]


def log_experiment(output_dir: Path, name: str, pngs: dict[str, Path],
                   documents: dict[str, str]) -> Path:
    """Write ``output_dir/<name>.rrd`` holding every PNG (under ``figures/<key>``) and every
    markdown text (under ``tables/<key>``). Returns the path."""
    from simcalib.report.rerun.studies import log_experiment as record
    return record(Path(output_dir) / f"{name}.rrd", name,
                  {k: Path(v) for k, v in pngs.items()}, dict(documents))
