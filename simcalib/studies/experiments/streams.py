"""Validation of the stream calibration: ``python -m simcalib experiment streams``.

Parts (``parts=[sync,ransac,roundtrip,eth]``):

* ``sync`` — time alignment in simulation (:func:`simcalib.world.stream_sim.rig_streams`: 3d and
  planar paths, offsets 0 / 37 / 250 ms, a at 30 Hz, b at 20 Hz);
* ``ransac`` — RANSAC on the paper's ``random`` motions with 20 % / 40 % outlier motions;
* ``roundtrip`` — a simulated run (``simcalib.run``: UR5e arm, 3d path, noisy poses) exported
  as files with a clock offset, outlier poses and b inverted + scalar-first
  (:func:`export_run_streams`), calibrated by the ``calibrate`` COMMAND, compared with the
  run's true X (:func:`roundtrip`; the same as ``tests/test_commands_calibrate.py``);
* ``eth`` — the two ETH hand_eye_calibration data sets (zips in ``eth_dir``, unpacked into
  the output folder), each calibrated by the ``calibrate`` COMMAND
  (``simcalib.cli.main(["calibrate", ...])``, outputs in ``<output>/eth/<set>/``); the table
  is read from the command's ``calibration.json`` files.

Writes ``streams.md`` (the tables of docs/calibrate.md) and ``streams.rrd``.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.studies.experiments.common import ExperimentResult
from simcalib.studies.experiments import experiment

__all__ = ["StreamsConfig", "run", "ETH_SETS", "eth_files", "sync_table", "ransac_table",
           "eth_table", "export_run_streams", "roundtrip", "roundtrip_table"]

PARTS = ("sync", "ransac", "roundtrip", "eth")

#: set -> (stream a = hand / Vicon body, stream b = camera): X = T_hand_camera
ETH_SETS = {
    "robot_arm_w_color_camera_sim": ("robot_arm_sim_hand.csv", "robot_arm_sim_camera.csv"),
    "prime_sense_1": ("2017-04-09-18-13-10_vicon_prime_sense.csv",
                      "2017-04-09-18-13-10_W_camera_rgb_image_raw.csv"),
}


@dataclass(frozen=True)
class StreamsConfig:
    parts: tuple[str, ...] = PARTS
    runs: int = 5
    ransac_runs: int = 50
    eth_dir: str = "../shared/data/eth"
    output: str = "results/streams"

    def __post_init__(self):
        from simcalib.config.checks import check_int, check_names, set_fields
        set_fields(self, parts=check_names("parts", self.parts, PARTS),
                   runs=check_int("runs", self.runs, lo=1),
                   ransac_runs=check_int("ransac_runs", self.ransac_runs, lo=1))


def eth_files(root, dest=None) -> dict:
    """Unpack the ETH zips in ``root`` into ``dest`` (default: a temporary folder);
    ``{set: (path_a, path_b)}`` for the sets found (a: hand / Vicon, b: camera)."""
    import tempfile
    import zipfile
    root = Path(root)
    out = Path(dest) if dest is not None else Path(tempfile.mkdtemp(prefix="simcalib_eth_"))
    out.mkdir(parents=True, exist_ok=True)
    for z in sorted(root.glob("*.zip")):
        with zipfile.ZipFile(z) as f:
            f.extractall(out)
    found = {}
    for name, (fa, fb) in ETH_SETS.items():
        pa = next(out.rglob(fa), None)
        pb = next(out.rglob(fb), None)
        if pa is not None and pb is not None:
            found[name] = (pa, pb)
    return found


def export_run_streams(run_dir, dest, *, offset_s: float = 0.037,
                       outlier_fraction: float = 0.03, subsample_b: int = 2,
                       seed: int = 5) -> tuple[Path, Path]:
    """Pose files of a simulated run's noisy streams, made as hard as real ones: a is the
    run's ``tum/cam_a_noisy.tum`` as written; b (``tum/cam_b_noisy.tum``) keeps every
    ``subsample_b``-th pose, is stamped ``offset_s`` late, has ``outlier_fraction`` of its
    poses replaced by gross outliers (random rotation, +-0.3 m), and is written INVERTED
    (``T_sensor_world``) with SCALAR-FIRST quaternions in the header-less ETH layout
    (``t, x, y, z, qw, qx, qy, qz``), so that only the data can tell the reading. Returns
    ``(path_a, path_b)``."""
    from simcalib.geometry import (invert_transform, quat_from_matrix,
                                   random_rotation_matrices,
                                   transform_from_rotation_translation)
    from simcalib.importers import read_pose_stream
    run_dir, dest = Path(run_dir), Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    b = read_pose_stream(run_dir / "tum" / "cam_b_noisy.tum")
    t = b.timestamps_s[::subsample_b] + offset_s
    T = np.array(b.T_world_sensor[::subsample_b])
    rng = np.random.default_rng(seed)
    k = int(round(outlier_fraction * t.size))
    idx = rng.choice(t.size, k, replace=False)
    T[idx] = T[idx] @ transform_from_rotation_translation(
        random_rotation_matrices(rng, (k,)), rng.uniform(-0.3, 0.3, (k, 3)))
    T = invert_transform(T)
    q = quat_from_matrix(T[:, :3, :3])
    path_b = dest / "b_camera_inverted_wxyz.csv"
    np.savetxt(path_b, np.column_stack([t, T[:, :3, 3], q[:, 3:], q[:, :3]]), fmt="%.10f",
               delimiter=", ")
    return run_dir / "tum" / "cam_a_noisy.tum", path_b


ROUNDTRIP_RUN = ["source=noisy", "noise.sigma_r_deg=0.1", "noise.sigma_t_m=0.001",
                 "world.fps=30", "recording.enabled=false", "solvers=[dqopt]"]


def roundtrip(output, *, scenario: str = "3d", offset_s: float = 0.037,
              outlier_fraction: float = 0.03) -> dict:
    """Simulate ``scenario`` (:data:`ROUNDTRIP_RUN` overrides), export its streams
    (:func:`export_run_streams`), calibrate them with ``simcalib calibrate`` and compare
    with the truth. Returns ``{"exit", "report" (calibration.json), "X_true",
    "offset_error_ms", "rotation_error_deg", "translation_error_mm",
    "plain_rotation_error_deg", "plain_translation_error_mm", "run_rotation_error_deg",
    "run_translation_error_mm"}`` (``run_*``: dqopt on the same poses, b subsampled alike,
    synchronous, outlier-free, same motion rule)."""
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import run
    from simcalib.solvers.api import solve
    from simcalib.cli import main
    from simcalib.geometry import rotation_error_rad, translation_error_m
    out = Path(output)
    cfg = load_config(scenario, ROUNDTRIP_RUN + [f"output={out / 'run'}",
                                                          "overwrite=true"])
    res = run(cfg)
    run_dir = Path(res.output_dir)
    X_true = np.array(json.loads((run_dir / "extrinsics.json").read_text())["X_true"]["T"])
    pa, pb = export_run_streams(run_dir, out / "files", offset_s=offset_s,
                                outlier_fraction=outlier_fraction)
    code = main(["calibrate", f"a={pa}", f"b={pb}", f"output={out / 'calibration'}",
                 "overwrite=true"])
    rep = json.loads((out / "calibration" / "calibration.json").read_text())
    X = np.array(rep["X"]["T_a_b"])
    Xp = np.array(rep["plain"]["X"]["T_a_b"])
    # reference: the same poses (b subsampled alike) synchronous, without outliers, same
    # motion rule, dqopt
    from simcalib.importers import read_pose_stream
    from simcalib.estimation.alignment import make_motions, synchronise
    sa, sb = (read_pose_stream(run_dir / "tum" / f"cam_{c}_noisy.tum") for c in "ab")
    sb = (sb.timestamps_s[::2], sb.T_world_sensor[::2])
    C, H, _, _ = make_motions(synchronise(sa, sb, 0.0), step_s=1.0, min_rotation_deg=2.0)
    Xs = solve(C, H).X
    return {"exit": code, "report": rep, "X_true": X_true, "offset_s": offset_s,
            "offset_error_ms": 1e3 * (rep["time_offset"]["offset_s"] - offset_s),
            "rotation_error_deg": math.degrees(float(rotation_error_rad(X, X_true))),
            "translation_error_mm": 1e3 * float(translation_error_m(X, X_true)),
            "plain_rotation_error_deg": math.degrees(float(rotation_error_rad(Xp, X_true))),
            "plain_translation_error_mm": 1e3 * float(translation_error_m(Xp, X_true)),
            "run_rotation_error_deg": math.degrees(float(rotation_error_rad(Xs, X_true))),
            "run_translation_error_mm": 1e3 * float(translation_error_m(Xs, X_true))}


def roundtrip_table(r: dict) -> str:
    rep = r["report"]
    c, off, inl = rep["conventions"], rep["time_offset"], rep["inliers"]
    reading = ("b inverted" if c["invert_b"] else "b as written") + (
        ", b quaternion order swapped" if c["swap_scalar_b"] else "")
    return "\n".join([
        "| exit | reading found (ratio) | offset true / estimated (ms) | motions / inliers | "
        "X error rot (deg) / trans (mm) | plain solve error rot / trans | same poses synchronous, "
        "no outliers: dqopt error rot / trans |",
        "|---|---|---|---|---|---|---|",
        f"| {r['exit']} | {reading} ({c['ratio']:.1f}x) | {1e3 * r['offset_s']:.1f} / "
        f"{1e3 * off['offset_s']:.2f} +- {1e3 * (off['uncertainty_s'] or 0):.2f} | "
        f"{inl['n_motions']} / {inl['n_inliers']} | {r['rotation_error_deg']:.3f} / "
        f"{r['translation_error_mm']:.2f} | {r['plain_rotation_error_deg']:.2f} / "
        f"{r['plain_translation_error_mm']:.1f} | {r['run_rotation_error_deg']:.3f} / "
        f"{r['run_translation_error_mm']:.2f} |"])


def calibrate_eth(eth_dir, output) -> dict:
    """Run ``simcalib calibrate`` on every ETH set; ``{set: (exit code, calibration.json
    content)}``."""
    from simcalib.cli import main
    out = Path(output)
    results = {}
    for name, (fa, fb) in eth_files(eth_dir, out / "data").items():
        d = out / name
        code = main(["calibrate", f"a={fa}", f"b={fb}", f"output={d}", "overwrite=true"])
        results[name] = (code, json.loads((d / "calibration.json").read_text()))
    return results


def eth_table(results: dict) -> str:
    """The ETH table of docs/calibrate.md from the command's calibration.json files."""
    rows = ["| data set | solve | exit | offset (ms) | motions | inliers | X translation (mm) | "
            "X rotation vector (deg) | 1-sigma rot (deg) / trans (mm) | "
            "residual rot median / rms (deg) | residual trans median / rms (mm) |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    f3 = lambda v, s=1.0: ", ".join(f"{s * x:.1f}" for x in v)  # noqa: E731

    def res(r):
        return (f"{r['rot_median_deg']:.3f} / {r['rot_rms_deg']:.3f} | "
                f"{r['trans_median_mm']:.2f} / {r['trans_rms_mm']:.2f}")
    for name, (code, rep) in results.items():
        off, inl, u = rep["time_offset"], rep["inliers"], rep["uncertainty"]
        sig = ("n/a" if u["std_rotation_deg"] is None else
               f"{max(u['std_rotation_deg']):.3f} / {1e3 * max(u['std_translation_m']):.2f}")
        sigma_ms = off["uncertainty_s"]
        rows.append(
            f"| {name} | {inl['robust']} + {rep['options']['method']}, offset estimated "
            f"({rep['verdict']['verdict']}) | {code} | {1e3 * off['offset_s']:.2f}"
            + (f" +- {1e3 * sigma_ms:.2f}" if sigma_ms else "")
            + f" | {inl['n_motions']} | {inl['n_inliers']} | "
            f"{f3(rep['X']['translation_m'], 1e3)} | {f3(rep['X']['rotvec_deg'])} | {sig} | "
            f"{res(rep['residuals']['inliers'])} |")
        al = rep["aligned_no_rejection"]
        rows.append(f"| {name} | dqopt, offset estimated, no rejection | | "
                    f"{1e3 * off['offset_s']:.2f} | {inl['n_motions']} | all | "
                    f"{f3(al['X']['translation_m'], 1e3)} | {f3(al['X']['rotvec_deg'])} | | "
                    f"{res(al['residuals'])} |")
        p = rep["plain"]
        rows.append(f"| {name} | plain dqopt, synchronous, no rejection | | 0 | "
                    f"{p['n_motions']} | all | {f3(p['X']['translation_m'], 1e3)} | "
                    f"{f3(p['X']['rotvec_deg'])} | | {res(p['residuals'])} |")
    return "\n".join(rows)


def sync_table(runs: int = 5) -> str:
    """Time alignment in simulation (``simcalib.world.stream_sim.rig_streams``): offset error and X
    error with the estimated / true offset / no alignment, ``runs`` seeds per row."""
    from simcalib.solvers.api import solve
    from simcalib.geometry import rotation_error_rad, translation_error_m
    from simcalib.world.stream_sim import rig_streams
    from simcalib.estimation.alignment import estimate_time_offset, make_motions, synchronise

    def x_err(rs, off):
        C, H, _, _ = make_motions(synchronise(rs.a, rs.b, off), step_s=0.5)
        X = solve(C, H).X
        return (math.degrees(float(rotation_error_rad(X, rs.X))),
                1e3 * float(translation_error_m(X, rs.X)))
    out = ["| path | offset (ms) | max abs offset error (ms) | mean reported sigma (ms) | "
           "X rot err, estimated / true offset (deg) | X trans err, estimated / true (mm) | "
           "X rot err without alignment (deg) |", "|---|---|---|---|---|---|---|"]
    for path in ("3d", "planar"):
        for off in (0.0, 0.037, 0.250):
            errs, sig, xe, xt, xn = [], [], [], [], []
            for seed in range(runs):
                rs = rig_streams(offset_s=off, path=path, rng=np.random.default_rng(seed))
                est = estimate_time_offset(rs.a, rs.b)
                errs.append(abs(est.offset_s - off))
                sig.append(est.uncertainty_s)
                xe.append(x_err(rs, est))
                xt.append(x_err(rs, off))
                xn.append(x_err(rs, 0.0))
            xe, xt, xn = np.median(xe, 0), np.median(xt, 0), np.median(xn, 0)
            out.append(f"| {path} | {off * 1e3:.0f} | {1e3 * max(errs):.3f} | "
                       f"{1e3 * np.mean(sig):.3f} | {xe[0]:.4f} / {xt[0]:.4f} | "
                       f"{xe[1]:.3f} / {xt[1]:.3f} | {xn[0]:.4f} |")
    return "\n".join(out)


def ransac_table(ransac_runs: int = 50) -> str:
    """RANSAC on the paper's ``random`` motions with injected outlier motions (gross: a random
    rigid motion; moderate: 5 deg / 5 cm corruption), ``ransac_runs`` seeds per row."""
    from simcalib.solvers.api import solve
    from simcalib.geometry import (perturb_transforms, random_rotation_matrices,
                                   rotation_error_rad, transform_from_rotation_translation,
                                   translation_error_m)
    from simcalib.solvers.robust import inlier_scores, ransac
    from simcalib.world.synthetic import synthetic_problem
    out = ["| outlier motions | kind | runs | median rot err clean / plain / RANSAC (deg) | "
           "median trans err clean / plain / RANSAC (cm) | RANSAC / clean | plain / clean | "
           "precision | recall | inliers found (prec >= .95, rec >= .9) |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for frac, kind in ((0.2, "gross"), (0.4, "gross"), (0.2, "moderate")):
        rows = []
        for seed in range(ransac_runs):
            rng = np.random.default_rng(seed)
            p = synthetic_problem("random", n=100, rng=rng)
            k = int(round(frac * 100))
            idx = rng.choice(100, k, replace=False)
            C = p.C.copy()
            if kind == "gross":      # a random rigid motion instead of the measured one
                C[idx] = transform_from_rotation_translation(
                    random_rotation_matrices(rng, (k,)), rng.uniform(-1, 1, (k, 3)))
            else:                    # the measured motion corrupted by 5 deg / 5 cm (1 sigma)
                C[idx] = perturb_transforms(C[idx], math.radians(5.0), 0.05, rng)
            good = np.ones(100, bool)
            good[idx] = False
            e = lambda X: (math.degrees(float(rotation_error_rad(X, p.X))),  # noqa: E731
                           100 * float(translation_error_m(X, p.X)))
            r = ransac(C, p.H, rng=np.random.default_rng(1000 + seed))
            sc = inlier_scores(r.inlier_mask, good)
            rows.append((*e(solve(p.C, p.H).X), *e(solve(C, p.H).X),
                         *e(r.X), sc["precision"], sc["recall"]))
        a = np.array(rows)
        m = np.median(a, 0)
        found = np.mean((a[:, 6] >= 0.95) & (a[:, 7] >= 0.9))
        out.append(f"| {frac:.0%} | {kind} | {ransac_runs} | "
                   f"{m[0]:.4f} / {m[2]:.3f} / {m[4]:.4f} | "
                   f"{m[1]:.3f} / {m[3]:.2f} / {m[5]:.3f} | {m[4] / m[0]:.2f} (rot), "
                   f"{m[5] / m[1]:.2f} (trans) | {m[2] / m[0]:.0f} (rot) | "
                   f"{a[:, 6].mean():.3f} | {a[:, 7].mean():.3f} | {found:.0%} |")
    return "\n".join(out)


@experiment('streams', config=StreamsConfig,
            description='validation of the stream calibration (time sync, RANSAC, round trip, ETH data)')
def run(cfg: StreamsConfig) -> ExperimentResult:
    from simcalib.studies.experiments import common
    from simcalib.studies.experiments.recording import log_experiment
    t0 = time.perf_counter()
    out = common.output_dir(cfg.output)
    docs, notes, extra = {}, [], {}
    if "sync" in cfg.parts:
        docs["sync"] = sync_table(cfg.runs)
    if "ransac" in cfg.parts:
        docs["ransac"] = ransac_table(cfg.ransac_runs)
    if "roundtrip" in cfg.parts:
        r = roundtrip(out / "roundtrip")
        docs["roundtrip"] = roundtrip_table(r)
        extra["roundtrip"] = r
    if "eth" in cfg.parts:
        if Path(cfg.eth_dir).is_dir():
            results = calibrate_eth(cfg.eth_dir, out / "eth")
            docs["eth"] = eth_table(results)
            extra["eth"] = results
            notes.append("ETH: " + ", ".join(f"{n} exit {c}" for n, (c, _) in results.items())
                         + f"; command outputs in {out / 'eth'}")
        else:
            notes.append(f"ETH data sets not found at {cfg.eth_dir}: part eth skipped")
    md = "\n\n".join(f"## {k}\n\n{v}" for k, v in docs.items()) + "\n"
    if notes:
        md += "\n" + "\n".join(f"- {n}" for n in notes) + "\n"
    (out / "streams.md").write_text(md)
    files = {"md": out / "streams.md",
             "rrd": log_experiment(out, "streams", {}, docs)}
    return ExperimentResult("streams", out, files, [], time.perf_counter() - t0, tuple(notes),
                            extra)
