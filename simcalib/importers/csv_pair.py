"""CSV holding both streams: one header, each stream's pose columns under its own prefix
(``robot_x, robot_qx, ..., cam_x, cam_qx, ...``; ``ee.position.x``; ``a/m00``...), the
way a script that logs the robot and the camera side by side writes them.

A prefix is what comes before the first ``_``, ``.`` or ``/`` of a column name whose rest
is a pose column of :mod:`simcalib.importers.csv` (position, quaternion in any order,
``q0..q3``, or a 4x4 matrix). The file is this format when exactly two prefixes carry a
whole pose; a stream is stamped by its own time column (``robot_time``, ``cam_stamp``)
where it has one, else by the file's (``time``, ``t``...), else by the row index. The
streams are named after their prefixes, in the header's order (a, b); rows where a
stream's values are empty or NaN (a camera that did not see the target) are that
stream's dropped rows, counted.
"""

from __future__ import annotations

import re

import numpy as np

from simcalib.importers import RawStream, data_error, pose_rows, register_format
from simcalib.importers import csv as _csv

NAME = "csv_pair"
DESCRIPTION = "CSV with both streams' pose columns under two prefixes (robot_x.., cam_x..)"
TWO_STREAMS = True


def _groups(names: list[str]) -> dict:
    """``{prefix: {column: role}}`` of the prefixes whose columns hold a whole pose, in
    the header's order (roles of :func:`simcalib.importers.csv.classify`)."""
    out: dict = {}
    for k, name in enumerate(names):
        clean = _csv._clean(name)
        for m in re.finditer(r"[._/]", clean):
            role = _csv.classify(clean[m.end():])
            if role:
                out.setdefault(clean[:m.start()], {})[k] = role
                break
    return {p: roles for p, roles in out.items() if _whole(roles)}


def _whole(roles: dict) -> bool:
    kinds = [r for r in roles.values()]
    pos = {r[1] for r in kinds if r[0] == "pos"}
    quat = {r[1] for r in kinds if r[0] == "quat"}
    return (sum(r[0] == "mat" for r in kinds) >= 12 or set("xyz") <= pos and (
        set("xyzw") <= quat or sum(r[0] == "q_index" for r in kinds) == 4))


def sniff(path, text: str) -> float:
    lineno, names = _csv._header(text)
    return 0.97 if names and len(_groups(names)) == 2 else 0.0


def _layout(roles: dict) -> tuple:
    by = lambda kind: {r[1]: k for k, r in roles.items() if r[0] == kind}  # noqa: E731
    return by("pos"), by("quat"), by("q_index"), by("mat")


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"csv_pair reader takes no options; received {sorted(options)}")
    lineno, names = _csv._header(text)
    groups = _groups(names) if names else {}
    if len(groups) != 2:
        raise data_error(f"{path}: {len(groups)} prefixes with a whole pose in the header "
                         f"({', '.join(groups) or 'none'}); csv_pair needs two")
    A, truncated = _csv._rows(path, text, lineno, len(names))
    grouped = {k for roles in groups.values() for k in roles}
    shared = [(k, sc) for k, sc in _csv._layout(names)[0] if k not in grouped]
    out = []
    for prefix, roles in groups.items():
        own = [(k, r[1]) for k, r in roles.items() if r[0] == "time"]
        t, synthetic, notes = _csv._times(A, own or shared)
        layout = _layout(roles)
        cols = [c for part in layout for c in part.values()]
        seen = np.all(np.isfinite(A[:, cols]), axis=1)
        repairs = {"truncated_last_row_dropped": 1} if truncated else {}
        if not seen.all():
            repairs["rows_without_this_stream_dropped"] = int((~seen).sum())
        out.append(_csv.raw_stream(path, A[seen], t[seen], layout, notes, synthetic, repairs,
                                   name=prefix))
    return out


def write(path, streams):
    """Two streams of as many poses, each with its own stamps: ``a_t, a_x, .., a_qw, b_t,
    b_x, .., b_qw`` (prefixes: the streams' names, else ``a`` / ``b``)."""
    a, b = streams
    if a.timestamps_s.shape != b.timestamps_s.shape:
        raise ValueError(f"csv_pair writes two streams of as many poses, row by row; received "
                         f"{a.timestamps_s.size} and {b.timestamps_s.size}")
    cols = "t,x,y,z,qx,qy,qz,qw".split(",")
    heads = [[f"{(s.name or d).replace(',', '_')}_{c}" for c in cols] for s, d in
             ((a, "a"), (b, "b"))]
    np.savetxt(path, np.column_stack([pose_rows(a), pose_rows(b)]), fmt="%.9f", delimiter=",",
               header=",".join(heads[0] + heads[1]), comments="")
    return [path]


register_format(__name__)
