"""The margin that tells a mirrored (left-handed) stream b (``MIRROR_RATIO`` of
:mod:`simcalib.estimation.readings`): the mirror ratio (best reading score with b as
written / with b mirrored) on files as written and on the same files with b mirrored
(``z -> -z``, quaternions ``(-qx, -qy, qz, qw)``), over generated recordings (kinds x
seeds) and the shared real sets, computed as ``calibrate`` computes it (the reading at the
first decision's offset, then :func:`~simcalib.estimation.readings.mirror_ratio`)::

    python -m simcalib.tools.mirror_margin --seeds 20            # every kind, seeds 0..19
    python -m simcalib.tools.mirror_margin --kinds planar --seeds 5 --real none

Prints one line per recording (JSON) with ``--lines``, then per kind the largest ratio as
written and the smallest mirrored, and the threshold's margins.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

__all__ = ["mirrored_file", "mirror_ratios", "main"]


def mirrored_file(stream, scalar_first: bool = False):
    """``stream`` (as read from a file) as a left-handed tool writes it: position ``z``
    and the quaternion's ``x``, ``y`` negated in the file's own numbers (``scalar_first``:
    the file writes ``w, x, y, z``, which the reader took for ``x, y, z, w``)."""
    from dataclasses import replace

    import numpy as np

    from simcalib.geometry import (matrix_from_quat, quat_from_matrix,
                                   transform_from_rotation_translation)
    T = np.asarray(stream.T_world_sensor)
    sign = np.array([1.0, -1.0, -1.0, 1.0] if scalar_first else [-1.0, -1.0, 1.0, 1.0])
    R = matrix_from_quat(quat_from_matrix(T[:, :3, :3]) * sign)
    return replace(stream, T_world_sensor=transform_from_rotation_translation(
        R, T[:, :3, 3] * np.array([1.0, 1.0, -1.0])))


def mirror_ratios(a, b, scalar_first_b: bool = False) -> dict:
    """``{"as_written": ratio, "mirrored": ratio, "pitch_as_written": agreement,
    "pitch_mirrored": agreement}`` of streams ``a``, ``b`` (PoseStreamData;
    ``scalar_first_b``: b's file is scalar-first) with b as written and as
    :func:`mirrored_file`, read as ``calibrate`` reads them up to the first reading
    (:func:`~simcalib.estimation.readings.mirror_ratio`,
    :func:`~simcalib.estimation.readings.pitch_agreement`)."""
    from simcalib.estimation.path import first_reading, read_pair
    from simcalib.estimation.readings import mirror_ratio, pitch_agreement
    from simcalib.estimation.sampling import classify_sampling
    from simcalib.estimation.stillness import check_streams_move
    from simcalib.estimation.world_jumps import longest_stretches, split_stations
    out = {}
    for tag, bb in (("as_written", b), ("mirrored", mirrored_file(b, scalar_first_b))):
        sa, sb = read_pair(a, bb)
        sa, sb, _ = longest_stretches(sa, sb)
        signal = check_streams_move(sa, sb)
        sa, sb, smp, _ = split_stations(sa, sb, classify_sampling(sa, sb))
        conv, off = first_reading(sa, sb, smp, signal=signal)
        at = dict(offset=off, sampling=smp, signal=signal)
        out[tag] = mirror_ratio(sa, sb, conv, **at)
        out[f"pitch_{tag}"] = pitch_agreement(sa, sb, conv, **at)
    return out


def _cases(kinds, seeds, real, first=0):
    from simcalib.studies.experiments.recording_kinds import KINDS, generate
    for seed in range(first, seeds):
        for k in kinds or [k for k, v in KINDS.items() if v.expect != "data_error"]:
            rec = generate(k, seed)
            yield k, f"{k} {seed}", rec.stream_a, rec.stream_b, rec.scalar_first_b
    if real != "none":
        from simcalib.importers import read_pose_stream
        from simcalib.studies.experiments.real_sets import SETS, set_available, set_paths
        for s in SETS:
            if s.source == "real" and set_available(s):
                a, b = set_paths(s)
                yield s.name, s.name, *(read_pose_stream(p, None, stamps_unit="pair")
                                        for p in (a, b)), False


def main(argv=None) -> int:
    from simcalib.errors import DataError
    from simcalib.estimation.readings import MIRROR_RATIO, PITCH_AGREEMENT
    ap = argparse.ArgumentParser(prog="python -m simcalib.tools.mirror_margin",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--kinds", nargs="*", default=None, help="default: every kind")
    ap.add_argument("--seeds", type=int, default=20, help="seeds FIRST..SEEDS-1 per kind")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--real", choices=("all", "none"), default="all")
    ap.add_argument("--lines", action="store_true", help="one JSON line per recording")
    args = ap.parse_args(argv)
    table: dict = {}
    for group, label, a, b, sf in _cases(args.kinds, args.seeds, args.real, args.first_seed):
        try:
            r = mirror_ratios(a, b, sf)
        except (DataError, ValueError) as exc:
            r = {"error": str(exc).splitlines()[0][:120]}
        if args.lines:
            print(json.dumps({"case": label} | r), flush=True)
        table.setdefault(group, []).append(r)
    _print_table(table, MIRROR_RATIO, PITCH_AGREEMENT)
    return 0


def _print_table(table: dict, threshold: float, pitch_skip: float) -> None:
    fmt = lambda v: "-" if v is None or not math.isfinite(v) else f"{v:.3g}"  # noqa: E731
    print(f"{'kind / set':<22} {'n':>3} {'as written: max':>16} {'mirrored: min':>14} "
          f"{'median':>8} {'told':>5} {'pitch: min as written':>22} {'max mirrored':>13}")
    worst_w, worst_p, told, n_m = 0.0, 0.0, 0, 0
    for g, rows in table.items():
        w = [r["as_written"] for r in rows if "as_written" in r]
        m = sorted(r["mirrored"] for r in rows if "mirrored" in r)
        pw = [r["pitch_as_written"] for r in rows if "pitch_as_written" in r]
        pm = [r["pitch_mirrored"] for r in rows if "pitch_mirrored" in r]
        t = sum(x > threshold for x in m)
        worst_w, told, n_m = max([worst_w] + w), told + t, n_m + len(m)
        worst_p = max([worst_p] + [x for x in pm if math.isfinite(x)])
        print(f"{g:<22} {len(rows):>3} {fmt(max(w) if w else None):>16} "
              f"{fmt(m[0] if m else None):>14} {fmt(m[len(m) // 2] if m else None):>8} "
              f"{t:>5} {fmt(min(pw) if pw else None):>22} {fmt(max(pm) if pm else None):>13}")
    print(f"threshold {threshold:g}: as written at most {worst_w:.3g} ({threshold / worst_w:.3g}x "
          f"below it); {told} of {n_m} mirrored told; the pitches of a mirrored b agree at "
          f"most {worst_p:.3g} (the scoring is skipped above {pitch_skip:g})")


if __name__ == "__main__":
    sys.exit(main())
