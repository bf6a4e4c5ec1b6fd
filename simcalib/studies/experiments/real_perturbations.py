"""Known perturbations of the public real recordings: does ``calibrate`` see through them?

Each set of ``../shared/data/real`` is calibrated with the defaults as it is (the base),
then with one perturbation at a time whose effect on the answer is known:

* ``offset+0.25s`` / ``offset-30s`` (continuous sets): b's stamps shifted; the offset must
  move by the shift (within 3 ms, or 3 of the larger offset sigma of the two runs: a base
  offset not told from 0 is known only to its sigma) and X stay;
* ``reset_b``: b's poses from the middle of the recording on in another world frame (a
  SLAM map reset, a bumped target: 0.8 m and 50 deg away): X must stay;
* ``epoch_b`` (continuous sets): b's clock made the other kind: stamps in Unix time
  counted from b's first pose, others moved to Unix time (+1.765e9 s); judged as a shift;
* ``drop20%b``, ``gap3s_a``, ``jitter2ms_b`` (continuous sets): rows dropped, a 3 s hole,
  +-2 ms stamp jitter: X must stay;
* ``invert_b`` (b written as ``T_sensor_world``), ``wxyz_b`` (b's quaternions scalar
  first), ``neg_quat_half_b`` (half of b's quaternions negated), ``shuffled_rows_b``
  (station sets: b's rows in random order), ``mirror_b`` (b written in a left-handed
  frame: ``z -> -z``, quaternions ``(-qx, -qy, qz, qw)``; read mirrored, b's poses are the
  set's own): X must stay;
* ``lost_row_b`` (station sets): b's row a third of the way in lost (a failed detection)
  and the later rows renumbered, so that b's rows take the stamps of a's first ones: X
  must stay;
* ``lost_rows_ab`` (station sets): a row lost in each file at different places (b's a
  third of the way in, a's two thirds), each file renumbered: every row still pairs by
  number, the rows between paired one off: X must stay;
* ``two_clocks_b`` (station sets): b stamped by another computer's clock, 2.3 s late with
  +-50 ms of trigger jitter (no stamp shared): X must stay;
* ``clock_step_b`` (continuous sets): b's clock steps by +0.4 s at its middle row (an NTP
  correction, a logger restarted): one clock step of 0.4 s (within 3 ms or 3 of its sigma)
  must be told and X stay;
* ``mm_b``: b's translations in millimetres: refused as a unit mismatch (exit 3) or
  calibrated with b rescaled (``scale_b``), X staying.

"X stays" means within the larger of 0.1 deg / 2 mm and 3 of the base's reported 1-sigma
(its largest finite rotation and translation entries; an axis the base leaves undetermined
is not compared). A run that warns that the reading of the files is not told by the data
(``conventions.clear`` false) and moves X is *flagged*, not failed: it says so.
Deterministic (one Generator per set, seeded by the set's position)::

    python -m simcalib.studies.experiments.real_perturbations [--sets NAME ...] [--output F]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.geometry import invert_transform, rotation_error_rad
from simcalib.studies.experiments import experiment

__all__ = ["PERTURBATIONS", "UNIX_EPOCH_S", "shift_s", "perturb", "run_set", "markdown",
           "main", "run", "RealPerturbationsConfig"]

#: name -> (applies to continuous sets, applies to station sets)
PERTURBATIONS = {
    "offset+0.25s": (True, False), "offset-30s": (True, False), "drop20%b": (True, False),
    "gap3s_a": (True, False), "jitter2ms_b": (True, False), "invert_b": (True, True),
    "wxyz_b": (True, True), "neg_quat_half_b": (True, True), "mm_b": (True, True),
    "shuffled_rows_b": (False, True), "epoch_b": (True, False), "reset_b": (True, True),
    "lost_row_b": (False, True), "two_clocks_b": (False, True),
    "mirror_b": (True, True), "lost_rows_ab": (False, True), "clock_step_b": (True, False)}
SHIFTS_S = {"offset+0.25s": 0.25, "offset-30s": -30.0}
#: ``clock_step_b``: b's clock steps by this much (s) at its middle row
CLOCK_STEP_S = 0.4
#: ``epoch_b`` moves stamps on a recording's clock by this much (a Unix time, 2025-12)
UNIX_EPOCH_S = 1.765e9


def shift_s(name: str, b: np.ndarray) -> float | None:
    """How far perturbation ``name`` moves b's stamps (None: it does not shift them)."""
    if name == "epoch_b":
        return -float(b[0, 0]) if b[0, 0] > 1e6 else UNIX_EPOCH_S
    return SHIFTS_S.get(name)


def _inverse_rows(rows: np.ndarray) -> np.ndarray:
    from simcalib.geometry import matrix_from_quat, quat_from_matrix
    T = np.tile(np.eye(4), (rows.shape[0], 1, 1))
    T[:, :3, :3] = matrix_from_quat(rows[:, 4:8])
    T[:, :3, 3] = rows[:, 1:4]
    Ti = invert_transform(T)
    return np.column_stack([rows[:, 0], Ti[:, :3, 3], quat_from_matrix(Ti[:, :3, :3])])


def _world_reset(rows: np.ndarray, k: int) -> np.ndarray:
    """TUM rows whose poses from row ``k`` on are moved into another world frame."""
    from simcalib.geometry import matrix_from_quat, matrix_from_rotvec, quat_from_matrix
    G = np.eye(4)
    G[:3, :3] = matrix_from_rotvec(np.radians(50.0) * np.array([0.6, -0.48, 0.64]))
    G[:3, 3] = [0.5, -0.4, 0.5]
    T = np.tile(np.eye(4), (len(rows) - k, 1, 1))
    T[:, :3, :3] = matrix_from_quat(rows[k:, 4:8])
    T[:, :3, 3] = rows[k:, 1:4]
    T = G @ T
    out = rows.copy()
    out[k:, 1:4], out[k:, 4:8] = T[:, :3, 3], quat_from_matrix(T[:, :3, :3])
    return out


def perturb(name: str, a: np.ndarray, b: np.ndarray, rng: np.random.Generator):
    """The TUM rows ``(a, b)`` (``t x y z qx qy qz qw``) under perturbation ``name``."""
    b = b.copy()
    if shift_s(name, b) is not None:
        b[:, 0] += shift_s(name, b)
    elif name == "drop20%b":
        b = b[rng.random(len(b)) > 0.2]
    elif name == "gap3s_a":
        g = a[0, 0] + 0.4 * (a[-1, 0] - a[0, 0])
        a = a[(a[:, 0] < g) | (a[:, 0] > g + 3.0)]
    elif name == "jitter2ms_b":
        b[:, 0] += rng.uniform(-0.002, 0.002, len(b))
    elif name == "invert_b":
        b = _inverse_rows(b)
    elif name == "wxyz_b":
        b[:, 4:8] = b[:, [7, 4, 5, 6]]
    elif name == "neg_quat_half_b":
        b[:, 4:8] *= np.where(rng.random(len(b)) < 0.5, -1.0, 1.0)[:, None]
    elif name == "mm_b":
        b[:, 1:4] *= 1000.0
    elif name == "reset_b":
        b = _world_reset(b, len(b) // 2)
    elif name == "shuffled_rows_b":
        b = b[rng.permutation(len(b))]
    elif name == "two_clocks_b":
        b[:, 0] += 2.3 + rng.uniform(-0.05, 0.05, len(b))
    elif name == "lost_row_b":
        b = np.delete(b, len(b) // 3, axis=0)
        b[:, 0] = a[:len(b), 0]
    elif name == "lost_rows_ab":                # a lost row 2n/3, b row n/3; both renumbered
        t = a[:, 0].copy()
        a, b = np.delete(a, 2 * len(a) // 3, axis=0), np.delete(b, len(b) // 3, axis=0)
        a[:, 0], b[:, 0] = t[:len(a)], t[:len(b)]
    elif name == "mirror_b":                    # a left-handed file: z -> -z, (-x, -y, z, w)
        b[:, [3, 4, 5]] *= -1.0
    elif name == "clock_step_b":                # b's clock steps half-way (NTP, a restart)
        b[len(b) // 2:, 0] += CLOCK_STEP_S
    elif name != "base":
        raise ValueError(f"unknown perturbation {name!r}; valid: base, "
                         + ", ".join(PERTURBATIONS))
    return a, b


@dataclass(frozen=True)
class Outcome:
    set: str
    perturbation: str
    exit_code: int
    verdict: str            # ok, flagged, FAIL
    detail: str


def _calibrate(a, b, folder: Path) -> tuple[int, dict | None, str]:
    from simcalib.cli import main as cli
    folder.mkdir(parents=True, exist_ok=True)
    for k, rows in (("a", a), ("b", b)):
        np.savetxt(folder / f"{k}.txt", rows, fmt="%.9f")
    import contextlib
    import io
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = cli(["calibrate", f"a={folder / 'a.txt'}", f"b={folder / 'b.txt'}",
                    f"output={folder / 'out'}", "overwrite=true", "recording=false"])
    path = folder / "out" / "calibration.json"
    cal = json.loads(path.read_text()) if code in (0, 6) and path.exists() else None
    return code, cal, err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else ""


def _bounds(cal: dict) -> tuple[float, float | None]:
    """The rotation (rad) and translation (m, None: not compared) an X may move by."""
    u = cal.get("uncertainty") or {}
    rot = [x for x in u.get("std_rotation_deg") or [] if x is not None]
    tra = [x for x in u.get("std_translation_m") or [] if x is not None]
    r = max(math.radians(0.1), 3 * math.radians(max(rot))) if rot else math.inf
    t = max(0.002, 3 * max(tra)) if len(tra) == 3 else None
    return r, t


def _offset_bound(base: dict, cal: dict) -> float:
    """How far the offset may move beyond the shift: 3 ms, or 3 of the larger reported
    sigma of the two runs (the base's offset, not told from 0, is known only to its
    sigma; the shifted run's, told, to its own)."""
    sig = [c["time_offset"].get("uncertainty_s") or 0.0 for c in (base, cal)]
    return max(3e-3, 3.0 * max(s for s in sig if math.isfinite(s)))


def _judge(name, base, code, cal, err, shift=None) -> tuple[str, str]:
    if name == "mm_b" and code == 3 and "different units" in err:
        return "ok", "refused: different units"
    if cal is None:
        return "FAIL", f"exit {code}: {err[:160]}"
    X0, X = (np.asarray(c["X"]["T_a_b"]) for c in (base, cal))
    dr = float(rotation_error_rad(X, X0))
    dt = float(np.linalg.norm(X[:3, 3] - X0[:3, 3]))
    r_max, t_max = _bounds(base)
    moved = f"X moved {math.degrees(dr):.3f} deg / {dt * 1e3:.1f} mm"
    off = cal["time_offset"]["offset_s"] - base["time_offset"]["offset_s"]
    shift = SHIFTS_S.get(name) if shift is None else shift
    if shift is not None and abs(off - shift) > _offset_bound(base, cal):
        return "FAIL", (f"offset moved {off * 1e3:.1f} ms, not {shift * 1e3:.1f} "
                        f"(+- {_offset_bound(base, cal) * 1e3:.1f}); {moved}")
    if name == "clock_step_b":
        told = _step_told(cal, moved)
        if told is not None:
            return "FAIL", told
    if dr <= r_max and (t_max is None or dt <= t_max):
        return "ok", moved
    if not cal["conventions"].get("clear", True):
        return "flagged", moved + " (the reading is not told: warned)"
    bound = f"{math.degrees(r_max):.3f} deg" + (
        "" if t_max is None else f" / {t_max * 1e3:.1f} mm")
    return "FAIL", f"{moved} (bound {bound})"


def _step_told(cal: dict, moved: str) -> str | None:
    """Why ``clock_step_b``'s step was not told right (None: it was, its size within 3 ms
    or 3 of its sigmas of :data:`CLOCK_STEP_S`)."""
    steps = cal["time_offset"].get("steps") or []
    if len(steps) != 1:
        return f"{len(steps)} clock steps told, not 1; {moved}"
    size, sig = steps[0]["size_s"], steps[0]["size_sigma_s"]
    if abs(size - CLOCK_STEP_S) > max(3e-3, 3.0 * sig):
        return f"clock step {size * 1e3:+.1f} +- {sig * 1e3:.1f} ms, not +400; {moved}"
    return None


def _continuous(a: np.ndarray) -> bool:
    return a[0, 0] > 1e6 or float(np.median(np.diff(a[:, 0]))) < 0.5


def run_set(name: str, folder: Path, work: Path, seed: int, names=None) -> list[Outcome]:
    """Every perturbation (``names``, default all that apply) of the set in ``folder``."""
    a = np.loadtxt(folder / "a.txt", comments="#")
    b = np.loadtxt(folder / "b.txt", comments="#")
    rng = np.random.default_rng(seed)
    cont = _continuous(a)
    code, base, err = _calibrate(a, b, work / name / "base")
    if base is None:
        return [Outcome(name, "base", code, "FAIL", err[:160])]
    out = []
    for p, (on_cont, on_stations) in PERTURBATIONS.items():
        if (names and p not in names) or not (on_cont if cont else on_stations):
            continue
        pa, pb = perturb(p, a, b, rng)
        code, cal, err = _calibrate(pa, pb, work / name / p)
        verdict, detail = _judge(p, base, code, cal, err, shift_s(p, b))
        out.append(Outcome(name, p, code, verdict, detail))
    return out


def markdown(outcomes: list[Outcome], command: str, total_s: float) -> str:
    n = len(outcomes)
    count = {v: sum(o.verdict == v for o in outcomes) for v in ("ok", "flagged", "FAIL")}
    lines = ["# Known perturbations of the real recordings", "",
             f"Generated by `{command}` ({total_s:.0f} s). Module doc: "
             "`simcalib.studies.experiments.real_perturbations`.", "",
             f"{n} perturbed runs: {count['ok']} ok, {count['flagged']} flagged (the reading "
             f"is not told by the data, and the run says so), {count['FAIL']} failed.", "",
             "| set | perturbation | exit | verdict | detail |", "|---|---|---|---|---|"]
    lines += [f"| {o.set} | {o.perturbation} | {o.exit_code} | {o.verdict} | {o.detail} |"
              for o in outcomes]
    return "\n".join(lines) + "\n"


def _sets(names) -> list[tuple[str, Path]]:
    from simcalib.studies.experiments.real_sets import SETS, real_dir
    from simcalib.errors import DataError
    sets = [(e.name, real_dir() / e.folder) for e in SETS if e.source == "real"
            and (not names or e.name in names)]
    sets = [(n, f) for n, f in sets if (f / "a.txt").exists()]
    if not sets:
        raise DataError(f"no real data set found under {real_dir()}" + (
            f" named {', '.join(names)}" if names else ""))
    return sets


def run_sets(names=None, perturbations=None, work=None) -> list[Outcome]:
    with tempfile.TemporaryDirectory(prefix="simcalib_perturb_") as tmp:
        out = []
        for k, (name, folder) in enumerate(_sets(names)):
            res = run_set(name, folder, Path(work or tmp), seed=k, names=perturbations)
            for o in res:
                print(f"{o.set} {o.perturbation}: exit {o.exit_code} {o.verdict} {o.detail}",
                      file=sys.stderr, flush=True)
            out += res
        return out


@dataclass(frozen=True)
class RealPerturbationsConfig:
    """``sets`` (empty: every real set), ``perturbations`` (empty: all that apply),
    ``output`` folder (writes ``real-perturbations.md``)."""
    sets: tuple[str, ...] = ()
    perturbations: tuple[str, ...] = ()
    output: str = "results/real_perturbations"

    def __post_init__(self):
        for p in self.perturbations:
            perturb(p, np.zeros((2, 8)), np.zeros((2, 8)), np.random.default_rng(0))


@experiment("real_perturbations", config=RealPerturbationsConfig,
            description="known perturbations of the real recordings, calibrated")
def run(cfg: RealPerturbationsConfig):
    from simcalib.studies.experiments.common import ExperimentResult, output_dir
    t0 = time.perf_counter()
    out = output_dir(cfg.output)
    outcomes = run_sets(cfg.sets or None, cfg.perturbations or None)
    path = out / "real-perturbations.md"
    path.write_text(markdown(outcomes, "python -m simcalib experiment real_perturbations",
                             time.perf_counter() - t0))
    fails = sum(o.verdict == "FAIL" for o in outcomes)
    return ExperimentResult("real_perturbations", out, {"md": path}, [],
                            time.perf_counter() - t0, (f"{fails} failed",),
                            {"outcomes": outcomes})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments."
                                "real_perturbations", description=__doc__.splitlines()[0])
    p.add_argument("--sets", nargs="*", default=None, metavar="NAME")
    p.add_argument("--perturbations", nargs="*", default=None, choices=list(PERTURBATIONS))
    p.add_argument("--output", default=None, help="markdown file to write")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    outcomes = run_sets(args.sets, args.perturbations)
    cmd = "python -m simcalib.studies.experiments.real_perturbations" + (
        " --sets " + " ".join(args.sets) if args.sets else "") + (
        f" --output {args.output}" if args.output else "")
    text = markdown(outcomes, cmd, time.perf_counter() - t0)
    if args.output:
        Path(args.output).write_text(text)
    print(text.splitlines()[4])
    return 1 if any(o.verdict == "FAIL" for o in outcomes) else 0


if __name__ == "__main__":
    raise SystemExit(main())
