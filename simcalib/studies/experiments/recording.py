"""The experiments' only contact with rerun: log an experiment's PNG figures and markdown
tables into ``<output>/<name>.rrd`` (headless, no viewer).

If the pipeline's :mod:`simcalib.report.rerun_log` offers ``log_experiment(path, name, images,
documents)`` it is used; otherwise this minimal fallback writes the recording itself.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["log_experiment"]


def log_experiment(output_dir: Path, name: str, pngs: dict[str, Path],
                   documents: dict[str, str]) -> Path:
    """Write ``output_dir/<name>.rrd`` holding every PNG (as ``rr.EncodedImage``, under
    ``figures/<key>``) and every markdown text (``rr.TextDocument``, under ``tables/<key>``).
    Returns the path."""
    path = Path(output_dir) / f"{name}.rrd"
    try:
        from simcalib.report import rerun_log
        shared = getattr(rerun_log, "log_experiment", None)
    except ImportError:
        shared = None
    if shared is not None:
        shared(path, name, {k: Path(v) for k, v in pngs.items()}, dict(documents))
        return path

    import rerun as rr

    rec = rr.RecordingStream(f"simcalib_experiment_{name}")
    rec.save(str(path))
    for key, png in pngs.items():
        rec.log(f"figures/{key}", rr.EncodedImage(path=str(png)), static=True)
    for key, text in documents.items():
        rec.log(f"tables/{key}", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN),
                static=True)
    rec.flush()
    rec.disconnect()
    return path
