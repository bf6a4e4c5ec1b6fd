"""Benchmark of the visual pose stage: accuracy per path and render+detect+PnP throughput.

``python -m simcalib bench-vision`` (or ``python -m simcalib.studies.bench.vision``) builds the
world of every requested path at default settings, renders both cameras, detects markers,
estimates poses and compares them with ground truth: per camera the median and 95th
percentile of the translation (mm) and rotation (deg) error, the frames used/dropped (with
reasons), and the throughput in camera frames per second (wall clock of the whole visual
stage, worker start-up included). ``--json`` writes the numbers.

``--targets``: board accuracy per target x camera-effect preset. For every target
(``marker_wall``, ``charuco``, ``apriltag_grid``) and preset (``ideal``, ``realistic``,
``harsh``) the world of a scenario (default ``handeye``: the UR5e's wrist camera looking at
the +x wall) is built with that target, rendered, detected and solved, and the camera's
estimated poses are compared with the rendered truth: median / p95 translation (mm) and
rotation (deg) error, frames used, drop reasons.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

__all__ = ["main", "bench_path", "bench_targets", "main_targets", "targets_markdown",
           "PRESET_NAMES"]


def bench_path(path: str, *, platform: str | None = None, duration_s: float | None = None,
               fps: float | None = None, vision_cfg=None, seed: int = 0,
               workers: int | None = None, world_kw: dict | None = None) -> dict:
    """Run the visual stage on one path; returns plain numbers (see module docstring).
    ``world_kw``: further ``WorldConfig`` fields (e.g. ``target``, ``rig``)."""
    from simcalib.geometry import rotation_error_rad, translation_error_m  # noqa: PLC0415
    from simcalib.sources.vision.config import VisionConfig  # noqa: PLC0415
    from simcalib.sources.vision.stream import visual_streams  # noqa: PLC0415
    from simcalib.world import WorldConfig, build_world  # noqa: PLC0415

    kw = {"path": path, "platform": platform, **(world_kw or {})}
    if duration_s is not None:
        kw["duration_s"] = duration_s
    if fps is not None:
        kw["fps"] = fps
    seeds = np.random.SeedSequence(seed).spawn(2)
    t0 = time.perf_counter()
    world = build_world(WorldConfig(**kw), np.random.default_rng(seeds[0]))
    t_world = time.perf_counter() - t0
    streams, log = visual_streams(world, vision_cfg or VisionConfig(),
                                  np.random.default_rng(seeds[1]), workers=workers)
    from simcalib.world.render_map import default_workers  # noqa: PLC0415
    cores = min(default_workers(), log.timing["workers"])
    cpu = log.timing["cpu_ms_per_frame"]
    out = {"path": path, "platform": world.config.platform, "world_build_s": t_world,
           "timing": log.timing, "cores": cores,
           "cpu_bound_frames_per_s": 1e3 * cores / cpu if cpu > 0 else float("inf"),
           "load_avg_1min": _loadavg(), "cameras": {}}
    for cam, st in streams.items():
        fr = world.frames(cam)
        T_true = fr.T_world_cam[st.frame_index]
        e_t = translation_error_m(st.T_world_cam, T_true) * 1e3
        e_r = np.rad2deg(rotation_error_rad(st.T_world_cam, T_true))
        vis = getattr(fr, "visible_markers", None)
        out["cameras"][cam] = {
            "n_frames": st.n_frames, "n_used": st.n_used, "drop_reasons": dict(st.drop_reasons),
            "median_mm": _q(e_t, 50), "p95_mm": _q(e_t, 95), "max_mm": _q(e_t, 100),
            "median_deg": _q(e_r, 50), "p95_deg": _q(e_r, 95), "max_deg": _q(e_r, 100),
            "median_markers_used": _q(st.info["n_markers"], 50),
            "median_reproj_rmse_px": _q(st.info["reproj_rmse_px"], 50),
            "median_markers_in_view": _q(np.asarray(vis), 50) if vis is not None else None,
            # pose flips: rotation error above 2 deg (a wrong IPPE branch / wrong fit)
            "n_flips": int((e_r > 2.0).sum()),
            "markers_occluded": log.summary()[cam]["markers_occluded"],
            "frames_with_occlusion": log.summary()[cam]["frames_with_occlusion"],
            "_err_mm": e_t, "_err_deg": e_r,
        }
    return out


def _loadavg() -> float:
    try:
        import os  # noqa: PLC0415
        return float(os.getloadavg()[0])
    except (OSError, AttributeError):
        return float("nan")


def _q(x, pct) -> float | None:
    x = np.asarray(x, dtype=np.float64)
    return float(np.percentile(x, pct)) if x.size else None


def _fmt(v, spec=".2f") -> str:
    return "-" if v is None else format(v, spec)


def _table(results: list[dict]) -> str:
    head = (f"{'path':<9} {'cam':<6} {'used/frames':>11} {'med mm':>7} {'p95 mm':>7} "
            f"{'med deg':>8} {'p95 deg':>8} {'mk':>4} {'rmse px':>7} {'drops':<28}")
    lines = [head, "-" * len(head)]
    for r in results:
        for cam, c in r["cameras"].items():
            drops = ",".join(f"{k}={v}" for k, v in sorted(c["drop_reasons"].items())) or "-"
            lines.append(
                f"{r['path']:<9} {cam:<6} {c['n_used']:>5}/{c['n_frames']:<5} "
                f"{_fmt(c['median_mm']):>7} {_fmt(c['p95_mm']):>7} "
                f"{_fmt(c['median_deg'], '.3f'):>8} {_fmt(c['p95_deg'], '.3f'):>8} "
                f"{_fmt(c['median_markers_used'], '.0f'):>4} "
                f"{_fmt(c['median_reproj_rmse_px'], '.3f'):>7} {drops:<28}")
        t = r["timing"]
        lines.append(f"{'':<9} throughput {t['frames_per_s']:.1f} camera frames/s wall "
                     f"({t['camera_frames']} frames in {t['wall_s']:.1f} s, workers="
                     f"{t['workers']}); CPU {t['cpu_ms_per_frame']:.1f} ms/frame -> "
                     f"{r['cpu_bound_frames_per_s']:.0f} frames/s on {r['cores']} idle cores; "
                     f"per frame render {t['render_ms_mean']:.1f} ms, detect "
                     f"{t['detect_ms_mean']:.1f} ms, PnP {t['pnp_ms_mean']:.1f} ms "
                     f"(load avg {r['load_avg_1min']:.1f})")
    return "\n".join(lines)


#: Rows of the effects table: (label, preset, overrides). "alone" rows take the realistic
#: preset's value of one effect with every other effect off.
def effect_rows() -> list[tuple[str, str, dict]]:
    from simcalib.sources.vision.camera_effects import PRESETS  # noqa: PLC0415
    r = PRESETS["realistic"]
    return [
        ("ideal (no effect)", "ideal", {}),
        ("distortion, true calibration", "ideal", {"distortion": r.distortion}),
        ("intrinsics error (+distortion)", "ideal", {"distortion": r.distortion,
                                                     "intrinsics_error": r.intrinsics_error}),
        ("sensor noise (read+shot)", "ideal", {"read_noise_dn": r.read_noise_dn,
                                               "shot_noise_dn": r.shot_noise_dn}),
        ("exposure/gain changes", "ideal", {"gain_log_std": r.gain_log_std}),
        ("JPEG", "ideal", {"compression_quality": r.jpeg_quality}),
        ("motion blur", "ideal", {"exposure_s": r.exposure_s, "subframes": r.subframes}),
        ("rolling shutter", "ideal", {"readout_s": r.readout_s, "subframes": r.subframes}),
        ("moving/changing light", "ideal", {"light_variation": r.light_variation,
                                            "light_motion_deg": r.light_motion_deg}),
        ("marker map error", "ideal", {"map_position_std_m": r.map_position_std_m,
                                       "map_rotation_std_deg": r.map_rotation_std_deg}),
        ("preset realistic", "realistic", {}),
        ("preset harsh", "harsh", {}),
    ]


def bench_effects(paths, *, duration_s=None, fps=None, seed=0, workers=None, rows=None,
                  echo=None) -> list[dict]:
    """Every row of :func:`effect_rows` on every path: pooled (both cameras) median error,
    frames used, occluded markers, and CPU ms per camera frame."""
    from simcalib.sources.vision.config import VisionConfig  # noqa: PLC0415
    out = []
    for label, preset, over in (rows or effect_rows()):
        cfg = VisionConfig(preset=preset, log_every=0, **over)
        row = {"effect": label, "preset": preset, "overrides": over, "paths": {}}
        for path in paths:
            r = bench_path(path, duration_s=duration_s, fps=fps, vision_cfg=cfg, seed=seed,
                           workers=workers)
            cams = r["cameras"].values()
            row["paths"][path] = {
                "median_mm": _q(np.concatenate([c["_err_mm"] for c in cams]), 50),
                "median_deg": _q(np.concatenate([c["_err_deg"] for c in cams]), 50),
                "p95_mm": _q(np.concatenate([c["_err_mm"] for c in cams]), 95),
                "used": sum(c["n_used"] for c in cams), "frames": sum(c["n_frames"] for c in cams),
                "flips": sum(c["n_flips"] for c in cams),
                "occluded": sum(c["markers_occluded"] for c in cams),
                "cpu_ms_per_frame": r["timing"]["cpu_ms_per_frame"],
            }
        cpu = [v["cpu_ms_per_frame"] for v in row["paths"].values()]
        row["cpu_ms_per_frame"] = float(np.mean(cpu))
        out.append(row)
        if echo is not None:
            echo(row)
    return out


def _effects_markdown(rows: list[dict], command: str) -> str:
    paths = list(rows[0]["paths"]) if rows else []
    head = "| effect | " + " | ".join(f"{p}: mm / deg (used)" for p in paths) + \
        " | CPU ms/frame | frames/s on 2 cores |"
    lines = [f"<!-- generated by `{command}` -->", head,
             "|" + "---|" * (len(paths) + 3)]
    for r in rows:
        cells = []
        for p in paths:
            c = r["paths"][p]
            cells.append(f"{_fmt(c['median_mm'])} / {_fmt(c['median_deg'], '.3f')} "
                         f"({c['used']}/{c['frames']}"
                         f"{', ' + str(c['flips']) + ' flips' if c['flips'] else ''})")
        ms = r["cpu_ms_per_frame"]
        lines.append(f"| {r['effect']} | " + " | ".join(cells) +
                     f" | {ms:.1f} | {2e3 / ms:.0f} |")
    return "\n".join(lines)


def _effects_text_row(r: dict) -> str:
    cells = "  ".join(f"{p} {_fmt(c['median_mm'])}mm/{_fmt(c['median_deg'], '.3f')}deg "
                      f"{c['used']}/{c['frames']}" for p, c in r["paths"].items())
    return f"{r['effect']:<32} {cells}  cpu {r['cpu_ms_per_frame']:.1f} ms/frame"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="simcalib bench-vision",
        description="Visual pose accuracy per path (median/p95 error vs ground truth per "
                    "camera, mm and deg) and render+detect+PnP throughput (camera frames/s).")
    p.add_argument("--paths", nargs="+", default=None,
                   help="paths to run (default: every registered path)")
    p.add_argument("--platform", default=None, choices=["cart", "arm"],
                   help="platform (default: the path's natural one)")
    p.add_argument("--duration", type=float, default=None, help="seconds (default: world's)")
    p.add_argument("--fps", type=float, default=None, help="frame rate (default: world's)")
    p.add_argument("--width", type=int, default=None, help="image width override")
    p.add_argument("--height", type=int, default=None, help="image height override")
    p.add_argument("--fovy", type=float, default=None, help="vertical fov override (deg)")
    p.add_argument("--noise", type=float, default=0.0, help="pixel noise std (grey levels)")
    p.add_argument("--blur", type=float, default=0.0, help="Gaussian blur sigma (px)")
    p.add_argument("--no-edge-refinement", action="store_true",
                   help="use OpenCV's corner refinement only")
    p.add_argument("--corner-refinement", default="subpix",
                   choices=["none", "subpix", "contour", "apriltag"])
    p.add_argument("--workers", type=int, default=None,
                   help="render worker processes (default: usable cores)")
    p.add_argument("--preset", default="ideal", choices=["ideal", "realistic", "harsh"],
                   help="camera-effect preset (default ideal)")
    p.add_argument("--effects", action="store_true",
                   help="tabulate each camera effect alone, then the presets (per path: "
                        "pooled median error of both cameras, frames used, CPU ms/frame)")
    p.add_argument("--markdown", default=None, metavar="FILE",
                   help="with --effects: write the table as Markdown to FILE, or replace "
                        "the generated table in FILE if it has one (e.g. docs/vision.md)")
    p.add_argument("--targets", nargs="+", default=None, metavar="TARGET",
                   help="board accuracy: every target (marker_wall, charuco, apriltag_grid) "
                        "x preset (ideal, realistic, harsh) in the world of --scenario; "
                        "with --markdown FILE the table replaces the generated one there")
    p.add_argument("--scenario", default="handeye",
                   help="with --targets: the scenario whose world is used (default handeye)")
    p.add_argument("--camera", default="cam_b",
                   help="with --targets: the camera reported (default cam_b, the wrist camera)")
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--json", default=None, help="write the results to this JSON file")
    return p


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    from simcalib.sources.vision.config import VisionConfig  # noqa: PLC0415
    from simcalib.world import available_paths  # noqa: PLC0415
    paths = args.paths or list(available_paths())
    known = list(available_paths())
    bad = [p for p in paths if p not in known]
    if bad:
        print(f"unknown path(s) {bad}; valid: {known}", file=sys.stderr)
        return 2
    try:
        cfg = VisionConfig(width=args.width, height=args.height, fovy_deg=args.fovy,
                           noise_std=args.noise, blur_sigma_px=args.blur,
                           corner_refinement=args.corner_refinement,
                           edge_refinement=not args.no_edge_refinement, preset=args.preset)
    except (TypeError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.effects:
        return _main_effects(args, paths, argv)
    if args.targets:
        return main_targets(args, argv)
    results = []
    for path in paths:
        r = bench_path(path, platform=args.platform, duration_s=args.duration, fps=args.fps,
                       vision_cfg=cfg, seed=args.seed, workers=args.workers)
        results.append(r)
        print(_table([r]), flush=True)
        cams = r["cameras"].values()
        pooled_mm = _q(np.concatenate([c["_err_mm"] for c in cams]), 50)
        pooled_deg = _q(np.concatenate([c["_err_deg"] for c in cams]), 50)
        print(f"{'':<9} both cameras pooled: median {_fmt(pooled_mm)} mm / "
              f"{_fmt(pooled_deg, '.3f')} deg", flush=True)
    total_frames = sum(r["timing"]["camera_frames"] for r in results)
    total_wall = sum(r["timing"]["wall_s"] for r in results)
    cpu_ms = sum(r["timing"]["cpu_ms_per_frame"] * r["timing"]["camera_frames"]
                 for r in results) / max(total_frames, 1)
    cores = results[0]["cores"] if results else 1
    print(f"\noverall throughput: {total_frames / total_wall:.1f} camera frames/s wall clock "
          f"({total_frames} frames in {total_wall:.1f} s); CPU {cpu_ms:.1f} ms per frame -> "
          f"{1e3 * cores / cpu_ms:.0f} frames/s on {cores} idle cores")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"config": {k: getattr(cfg, k) for k in cfg.__dataclass_fields__},
                       "results": _public(results)}, fh, indent=2, default=_json_default)
    return 0


def _public(obj):
    """Drop the private raw-error arrays (keys starting with ``_``) for JSON output."""
    if isinstance(obj, dict):
        return {k: _public(v) for k, v in obj.items() if not str(k).startswith("_")}
    if isinstance(obj, list):
        return [_public(v) for v in obj]
    return obj


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer,)):
        return int(o)
    return float(o)


MARK_BEGIN = "<!-- bench-vision effects table: begin -->"
MARK_END = "<!-- bench-vision effects table: end -->"


def _main_effects(args, paths, argv) -> int:
    import os  # noqa: PLC0415
    rows = bench_effects(paths, duration_s=args.duration, fps=args.fps, seed=args.seed,
                         workers=args.workers,
                         echo=lambda r: print(_effects_text_row(r), flush=True))
    cmd = "python -m simcalib bench-vision " + " ".join(
        a for a in (argv if argv is not None else sys.argv[1:]))
    md = _effects_markdown(rows, cmd.strip())
    print()
    print(md)
    if args.markdown:
        block = f"{MARK_BEGIN}\n{md}\n{MARK_END}"
        text = open(args.markdown).read() if os.path.exists(args.markdown) else ""
        if MARK_BEGIN in text and MARK_END in text:
            a = text.index(MARK_BEGIN)
            b = text.index(MARK_END) + len(MARK_END)
            text = text[:a] + block + text[b:]
        else:
            text = (text + "\n\n" if text else "") + block + "\n"
        with open(args.markdown, "w") as fh:
            fh.write(text)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(_public(rows), fh, indent=2, default=_json_default)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

PRESET_NAMES = ("ideal", "realistic", "harsh")
MARK_BEGIN = "<!-- bench-vision targets table: begin -->"
MARK_END = "<!-- bench-vision targets table: end -->"


def _scenario_world(name: str) -> dict:
    import yaml  # noqa: PLC0415
    from simcalib.config.resources import scenarios_dir  # noqa: PLC0415
    path = scenarios_dir() / f"{name}.yaml"
    if not path.exists():
        valid = sorted(p.stem for p in scenarios_dir().glob("*.yaml"))
        raise ValueError(f"unknown scenario {name!r}; valid: {valid}")
    world = dict((yaml.safe_load(path.read_text()) or {}).get("world") or {})
    if not world:
        raise ValueError(f"scenario {name!r} has no world section (a simulated one is needed)")
    return world


def bench_targets(targets, presets=PRESET_NAMES, *, scenario: str = "handeye",
                  camera: str = "cam_b", duration_s=None, seed: int = 0, workers=None,
                  echo=None) -> list[dict]:
    """One row per (target, preset): the camera's pose errors against the rendered truth."""
    from simcalib.targets.boards import check_target  # noqa: PLC0415
    from simcalib.sources.vision.config import VisionConfig  # noqa: PLC0415
    world = _scenario_world(scenario)
    rows = []
    for target in targets:
        check_target(target)
        for preset in presets:
            kw = {k: v for k, v in world.items() if k not in ("path", "platform")}
            kw["target"] = target
            if duration_s is not None:
                kw["duration_s"] = duration_s
            r = bench_path(world.get("path", "planar"), platform=world.get("platform"),
                           vision_cfg=VisionConfig(preset=preset, log_every=0), seed=seed,
                           workers=workers, world_kw=kw)
            c = r["cameras"][camera]
            row = {"target": target, "preset": preset, "camera": camera,
                   "n_used": c["n_used"], "n_frames": c["n_frames"],
                   "drop_reasons": c["drop_reasons"],
                   "median_mm": _q(c["_err_mm"], 50), "p95_mm": _q(c["_err_mm"], 95),
                   "median_deg": _q(c["_err_deg"], 50), "p95_deg": _q(c["_err_deg"], 95),
                   "median_points": c["median_markers_used"],
                   "median_reproj_rmse_px": c["median_reproj_rmse_px"]}
            rows.append(row)
            if echo is not None:
                echo(row)
    return rows


def targets_markdown(rows: list[dict], command: str) -> str:
    """The rows as a Markdown table, headed by the command that regenerates it."""
    lines = [f"<!-- generated by `{command}` -->",
             "| target | preset | median mm | p95 mm | median deg | p95 deg | used/frames | "
             "median markers or corners used | median RMSE px | drops |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        drops = ", ".join(f"{k} {v}" for k, v in sorted(r["drop_reasons"].items())) or "-"
        lines.append(
            f"| {r['target']} | {r['preset']} | {_fmt(r['median_mm'])} | {_fmt(r['p95_mm'])} "
            f"| {_fmt(r['median_deg'], '.3f')} | {_fmt(r['p95_deg'], '.3f')} | "
            f"{r['n_used']}/{r['n_frames']} | {_fmt(r['median_points'], '.0f')} | "
            f"{_fmt(r['median_reproj_rmse_px'], '.3f')} | {drops} |")
    return "\n".join(lines)


def _replace_block(path: str, md: str) -> None:
    block = f"{MARK_BEGIN}\n{md}\n{MARK_END}"
    text = open(path).read() if os.path.exists(path) else ""
    if MARK_BEGIN in text and MARK_END in text:
        a, b = text.index(MARK_BEGIN), text.index(MARK_END) + len(MARK_END)
        text = text[:a] + block + text[b:]
    else:
        text = (text + "\n\n" if text else "") + block + "\n"
    with open(path, "w") as fh:
        fh.write(text)


def main_targets(args, argv) -> int:
    """``bench-vision --targets ...`` (see :func:`bench_targets`)."""
    from simcalib.errors import ConfigError  # noqa: PLC0415
    presets = (args.preset,) if "--preset" in (argv if argv is not None else sys.argv) \
        else PRESET_NAMES
    try:
        rows = bench_targets(args.targets, presets, scenario=args.scenario,
                             camera=args.camera, duration_s=args.duration, seed=args.seed,
                             workers=args.workers,
                             echo=lambda r: print(f"{r['target']:<14} {r['preset']:<10} "
                                                  f"median {r['median_mm']} mm / "
                                                  f"{r['median_deg']} deg, used "
                                                  f"{r['n_used']}/{r['n_frames']}",
                                                  flush=True))
    except (ConfigError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    cmd = "python -m simcalib bench-vision " + " ".join(argv if argv is not None
                                                        else sys.argv[1:])
    md = targets_markdown(rows, cmd.strip())
    print()
    print(md)
    if args.markdown:
        _replace_block(args.markdown, md)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=2, default=float)
    return 0
