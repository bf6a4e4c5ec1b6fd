"""``python -m simcalib.world [--duration S] [--fps F] [--seed N]``: build every sensible
platform/path pair at default settings and print build/simulate times, IK accuracy and
marker visibility (the numbers in docs/world.md)."""

from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    import numpy as np

    from simcalib.world import WorldConfig, available_paths, build_world
    ap = argparse.ArgumentParser(prog="python -m simcalib.world", description=__doc__)
    ap.add_argument("--duration", type=float, default=20.0, help="seconds (default 20)")
    ap.add_argument("--fps", type=float, default=10.0, help="frames per second (default 10)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    print(f"{'platform':8} {'path':9} {'frames':>6} {'build s':>8} {'sim s':>7} "
          f"{'IK max mm':>10} {'IK max deg':>10} {'IK it':>6} {'vis a min/med':>14} "
          f"{'vis b min/med':>14}")
    for name, info in sorted(available_paths().items()):
        for platform in info.platforms:
            cfg = WorldConfig(platform=platform, path=name, duration_s=args.duration,
                              fps=args.fps)
            w = build_world(cfg, np.random.default_rng(args.seed))
            va = w.trajectory.cam_a.visible_markers
            vb = w.trajectory.cam_b.visible_markers
            ik = w.ik if w.ik and "mean_iterations" in w.ik else {}   # IK platforms only
            ik_mm = f"{ik['max_pos_error_m'] * 1e3:.1e}" if ik else "-"
            ik_deg = f"{np.rad2deg(ik['max_rot_error_rad']):.1e}" if ik else "-"
            ik_it = f"{ik['mean_iterations']:.1f}" if ik else "-"
            print(f"{platform:8} {name:9} {cfg.n_frames:6d} {w.timing_s['build_scene']:8.2f} "
                  f"{w.timing_s['simulate']:7.2f} {ik_mm:>10} {ik_deg:>10} {ik_it:>6} "
                  f"{va.min():>6d}/{np.median(va):<7.0f} {vb.min():>6d}/{np.median(vb):<7.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
