"""Reading rerun recordings back in tests (shared by the recording tests)."""

from types import SimpleNamespace

import numpy as np


def chunks(rrd):
    """{entity: {column: [values...]}} of the recording (not the blueprint)."""
    from rerun.chunk import RrdReader
    out: dict[str, dict[str, list]] = {}
    for ch in RrdReader(str(rrd)).store().stream():
        rb = ch.to_record_batch()
        cols = out.setdefault(str(ch.entity_path), {})
        for name in rb.schema.names:
            if ":" in name:
                cols.setdefault(name, []).extend(rb.column(name).to_pylist())
    return out


def points(values) -> np.ndarray:
    """All 3-vectors inside a nested list of component values."""
    flat = []

    def walk(v):
        if isinstance(v, (list, tuple)):
            if len(v) == 3 and all(isinstance(x, (int, float)) for x in v):
                flat.append(v)
            else:
                for x in v:
                    walk(x)
    walk(values)
    return np.array(flat, dtype=np.float64).reshape(-1, 3)


def solver_stub(label, X, rot=0.1, trans=0.01, cov=None):
    """A stand-in for a run's SolverResult (what the recorder reads of it)."""
    ns = SimpleNamespace(label=label, X=X, rotation_error_deg=None if X is None else rot,
                         translation_error_m=None if X is None else trans,
                         translation_error_determined_m=None if X is None else trans,
                         degenerate=False, alpha=1.0, error=None if X is not None else "boom",
                         undetermined_directions=(), undetermined=(), runtime_s=1e-3,
                         undetermined_translation_axes=None, prior=None, covariance=None,
                         sigma_rotation_deg=None, sigma_translation_m=None,
                         verdict="determined" if X is not None else "FAILED")
    if cov is not None:
        ns.covariance = cov
    return ns
