"""Reading rerun recordings back in tests (shared by the recording tests)."""

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
