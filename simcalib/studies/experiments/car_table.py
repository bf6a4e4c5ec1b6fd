"""The docs/physics.md table: how much of X's vertical translation the car's natural roll
and pitch determine, and what a prior recovers.

``python -m simcalib.studies.experiments.car_table`` runs the ``car`` scenario (noisy poses) on the
figure-eight at three speeds on three grounds (rigid car on flat ground; sprung car on
uneven ground with 1 cm and 4 cm bumps), five seeds each, and prints for each cell the
actual error of dqopt's translation of X along the car's vertical (median / max over the
seeds), dqopt's predicted 1-sigma (Solution.uncertainty) along it, the error of dqopt with the prior, and the
prior's (nominal X's) own vertical error. The capture window of each run covers the whole
drive at that speed.
"""

from __future__ import annotations

import math
import time

import numpy as np

from simcalib.world.platforms.car import car_path, vertical_axis_a

__all__ = ["vertical_error_table", "format_vertical_table", "main"]


def _target_fn(world_cfg):
    """The target frame's path of a world config (car: home = identity), no scene."""
    from simcalib.world.paths import compose_path, sample_path

    def fn(tt):
        return compose_path(np.eye(4), sample_path(world_cfg.path, world_cfg.platform, tt,
                                                   world_cfg.duration_s,
                                                   world_cfg.path_params))
    return fn


def vertical_error_table(speeds_mps=(3.0, 4.5, 6.0), bumps_m=(0.01, 0.04),
                         seeds=(0, 1, 2), scenario: str = "car", extra=(),
                         out_dir: str | None = None) -> list[dict]:
    """Rows of the docs table: for each ground (the rigid car on flat ground, then the
    sprung car on uneven ground of each bump height) and speed, runs of ``scenario`` with
    those settings, one per seed: |error of X's translation along the car's vertical| of
    dqopt and of dqopt with the prior (median and max over the seeds), the nominal
    (prior) X's own vertical error, dqopt's predicted 1-sigma (Solution.uncertainty) along the vertical.
    Run directories go to ``out_dir`` (default: a temporary directory, removed)."""
    import tempfile
    if out_dir is None:
        with tempfile.TemporaryDirectory(prefix="simcalib-car-table-") as tmp:
            return vertical_error_table(speeds_mps, bumps_m, seeds, scenario, extra, tmp)
    from simcalib.pipeline.scenario import load_config
    base = load_config(scenario, ["progress=false"])
    length_m = float(car_path(_target_fn(base.world), base.world).arc_length_m[-1])
    vc = base.world.vehicle
    variants = [("rigid, flat", ["world.vehicle.sprung=false", "world.vehicle.ground=flat"])]
    variants += [(f"sprung, bumps {b * 100:g} cm",
                  ["world.vehicle.sprung=true", "world.vehicle.ground=uneven",
                   f"world.vehicle.bump_amplitude_m={b}"]) for b in bumps_m]
    rows = []
    for label, over in variants:
        for v in speeds_mps:
            # the capture window covers the whole drive at this speed
            drive_s = length_m / v + v / (2 * vc.accel_mps2) + v / (2 * vc.decel_mps2)
            over_v = [*over, f"world.vehicle.speed_mps={v}",
                      f"world.duration_s={math.ceil(drive_s + 1.0)}"]
            runs = [_vertical_run(scenario, over_v, seed, extra,
                                  f"{out_dir}/{label.replace(' ', '').replace(',', '-')}"
                                  f"-{v:g}-{seed}") for seed in seeds]
            rows.append(_vertical_row(label, v, runs))
    return rows


def _vertical_run(scenario: str, overrides: list, seed: int, extra, output: str) -> dict:
    """One run of the table: its vertical errors (dqopt, dqopt+prior, the nominal X), the
    flag, the motions used, dqopt's 1-sigma along the vertical and the wall time."""
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import run
    cfg = load_config(scenario, [*overrides, f"seed={seed}", "progress=false",
                                 "recording.enabled=false", f"output={output}",
                                 "overwrite=true", *extra])
    up = vertical_axis_a(cfg.world)
    t0 = time.perf_counter()
    res = run(cfg, echo=False)
    wall = time.perf_counter() - t0
    t_true = res.X_true[:3, 3]
    err = {name: (abs(float((res.solver(name).X[:3, 3] - t_true) @ up))
                  if res.solver(name).X is not None else float("nan"))
           for name in ("dqopt", "dqopt+prior")}
    s = res.solver("dqopt")
    stds = [d["std_m"] for d in s.undetermined_directions
            if d["kind"] == "translation" and abs(np.dot(d["translation_dir_a"], up)) > 0.9]
    nominal = np.asarray(res.solver("dqopt+prior").prior["X"])
    return {"dqopt": err["dqopt"], "prior": err["dqopt+prior"],
            "nominal": abs(float((nominal[:3, 3] - t_true) @ up)),
            "flagged": int(bool(s.degenerate)), "n_motions": int(res.pairing.get("used", 0)),
            "obs_std": stds[0] if stds else 0.0, "wall": wall}


def _vertical_row(label: str, v: float, runs: list[dict]) -> dict:
    """The table row of one ground and speed over its seeds' runs."""
    col = lambda k: [r[k] for r in runs]  # noqa: E731
    return {"variant": label, "speed_mps": float(v), "n_seeds": len(runs),
            "n_motions": runs[-1]["n_motions"] if runs else 0,
            "obs_std_median_m": float(np.median(col("obs_std"))),
            "dqopt_vert_median_m": float(np.median(col("dqopt"))),
            "dqopt_vert_max_m": float(np.max(col("dqopt"))),
            "prior_vert_median_m": float(np.median(col("prior"))),
            "prior_vert_max_m": float(np.max(col("prior"))),
            "nominal_vert_median_m": float(np.median(col("nominal"))),
            "flagged_degenerate": sum(col("flagged")),
            "wall_s": float(np.median(col("wall")))}


def format_vertical_table(rows) -> str:
    head = ("| car, ground | speed m/s | motions | dqopt vertical error median / max cm "
            "| predicted 1-sigma (median) cm | dqopt+prior vertical error median / max "
            "cm | nominal X vertical error median cm | run s |")
    lines = [head, "|" + "---|" * 8]
    for r in rows:
        lines.append(
            f"| {r['variant']} | {r['speed_mps']:g} | {r['n_motions']} "
            f"| {100 * r['dqopt_vert_median_m']:.2f} / {100 * r['dqopt_vert_max_m']:.2f} "
            f"| {100 * r['obs_std_median_m']:.1f} "
            f"| {100 * r['prior_vert_median_m']:.2f} / {100 * r['prior_vert_max_m']:.2f} "
            f"| {100 * r['nominal_vert_median_m']:.2f} | {r['wall_s']:.0f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.car_table",
                                 description="Regenerate the docs/physics.md table of X's "
                                             "vertical translation on the car.")
    ap.add_argument("--table", action="store_true", help="print the docs table")
    ap.add_argument("--seeds", type=int, default=5, help="runs per cell (seeds 0..n-1)")
    ap.add_argument("--scenario", default="car")
    args = ap.parse_args(argv)
    if not args.table:
        ap.print_help()
        return 0
    print(format_vertical_table(vertical_error_table(seeds=tuple(range(args.seeds)),
                                                     scenario=args.scenario)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
