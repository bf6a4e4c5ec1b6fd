"""``simcalib advise scenario=NAME [k=5] [verify=true] [output=DIR] [key=value ...]``:
which motions to record next (docs/advice.md)."""

from __future__ import annotations

import json
import math
from pathlib import Path

from simcalib.cli import command
from simcalib.errors import UsageError

USAGE = """usage: python -m simcalib advise scenario=NAME [k=5] [verify=true|false]
       [seeds=5] [candidates=1000] [output=DIR] [key=value ...] [--debug]
   or: python -m simcalib advise a=PATH b=PATH platform=free|cart output=DIR [k=5]
       [candidates=1000] [calibrate key=value ...]

Proposes the next k stop-and-go motions of the platform that most reduce the predicted
uncertainty of X (greedy over feasible candidates: IK within joint limits, no
self-collision, markers visible and detected in the render for ArUco cameras), after the
scenario's recorded run. With verify=true the advised stops are executed in the
simulator (render, detect, solve with dqopt) and compared with k random feasible stops
for `seeds` seeds. Writes DIR/advice.json and DIR/advice.rrd (proposed poses in 3D);
prints the predicted 1-sigma per axis before and after each motion.

Advice options: k, verify, seeds, candidates, max_rotation_deg, max_translation_m
(the stops drawn: arm up to 90 deg / 0.30 m by default, cart 90 deg / 1 m),
min_markers, recording (true|false), force (default true: propose k motions even when
the recorded motions already determine X within the tolerance; false: none then),
systematic (true|false, default true: weigh the marker map's and the calibrations' errors
the ArUco poses share, see docs/advice.md), stop_frames (verification: frames recorded
and averaged at each stop while the platform rests, default 1), hindsight (verification:
also the k stops a chooser knowing the true X would pick: what the candidates can give on
this rig, not advice; default false), floor (true|false, default false: also the model's
floor, the smallest expected error any choice of k of the candidates reaches by the
planner's error model, against k random stops: whether a better choice could gain more;
no simulation, about a minute). Every other key=value is a scenario override
(see `run --help`), e.g. world.platform=arm.

With a=PATH (your own pose files): the files are calibrated as `calibrate` does (every
calibrate key applies: format, time_offset, robust, alpha, ...) and the next k stops of
sensor a are proposed from its last recorded pose. platform=free: any rotation up to
90 deg and move up to 30 cm (nothing about your robot or scene is checked: check each
stop before recording it); platform=cart: yaw about the plane the recorded motions lie
in (up to 90 deg) and planar moves up to 1 m. Options k, candidates, max_rotation_deg,
max_translation_m, force, recording. No verification (there is no simulator of your rig).
"""

ADVICE_KEYS = {"k": int, "verify": bool, "seeds": int, "candidates": int, "stop_frames": int,
               "max_rotation_deg": float, "max_translation_m": float, "min_markers": int,
               "recording": bool, "force": bool, "systematic": bool, "hindsight": bool,
               "floor": bool}


def _value(key, text):
    typ = ADVICE_KEYS[key]
    t = text.strip().lower()
    if typ is bool:
        if t in ("true", "yes", "1", "on"):
            return True
        if t in ("false", "no", "0", "off"):
            return False
        raise UsageError(f"{key} must be true or false; received {text!r}")
    try:
        v = typ(t)
    except ValueError:
        raise UsageError(f"{key} must be {'an integer' if typ is int else 'a number'}; "
                         f"received {text!r}") from None
    if typ is int and v < 1 or (typ is float and not (math.isfinite(v) and v > 0)):
        raise UsageError(f"{key} must be > 0; received {text!r}")
    return v


def parse_args(args):
    from simcalib.studies.advise.advisor import N_CANDIDATES
    from simcalib.commands.run import parse_args as run_args
    opts = {"k": 5, "verify": False, "seeds": 5, "candidates": N_CANDIDATES, "recording": True}
    rest = []
    for a in args:
        key, eq, val = a.partition("=")
        if eq and key.strip() in ADVICE_KEYS:
            opts[key.strip()] = _value(key.strip(), val)
        else:
            rest.append(a)
    scenario, overrides, _ = run_args(rest)
    return scenario, overrides, opts


def _std_row(label, s) -> str:
    vals = [s.get(a) for a in ("wx_deg", "wy_deg", "wz_deg")]
    tr = [s.get(a) for a in ("vx_m", "vy_m", "vz_m")]
    f = lambda v, m=1.0: "    inf" if v is None else f"{v * m:7.3f}"   # noqa: E731
    return f"{label:<10}" + " ".join(f(v) for v in vals) + "  " + " ".join(
        f(v, 100) for v in tr)


def _print_std_rows(out: dict) -> None:
    print("predicted 1-sigma   wx      wy      wz [deg]   vx      vy      vz [cm]")
    print(_std_row("before", out["predicted_std_before"]))
    for m in out["motions"]:
        print(_std_row(f"+ stop {m['step']}", m["predicted_std_after"]))


def _print_notes(out: dict) -> None:
    if out.get("message"):
        print(out["message"])
    for c in out["cannot_help"]:
        print(f"cannot help: {c['statement']}. Fix: {c['fix']}")
    if (out.get("limited_by") or {}).get("statement"):
        print(f"after the stops, {out['limited_by']['statement']}")
    eg = out.get("expected_gain") or {}
    if eg:
        print(f"expected (predicted largest 1-sigma, no simulation): these stops "
              f"{_n(eg['advised_max_std_deg'])} deg / {_n(eg['advised_max_std_cm'])} cm; "
              f"{eg['stops']} random stops of the same candidates (median of {eg['chains']}) "
              f"{_n(eg['random_max_std_deg_median'])} deg / "
              f"{_n(eg['random_max_std_cm_median'])} cm")
    fl = out.get("choice_floor") or {}
    if fl:
        print(f"model floor (expected RMS error, no simulation): the best choice of "
              f"{fl['stops']} of these candidates found {_n(fl['floor_expected_deg'])} deg / "
              f"{_n(fl['floor_expected_cm'])} cm; these stops {_n(fl['advised_expected_deg'])}"
              f" / {_n(fl['advised_expected_cm'])}; {fl['stops']} random stops "
              f"{_n(fl['random_expected_deg'])} / {_n(fl['random_expected_cm'])} (floor / "
              f"random: rotation {_n(fl['ratio_floor_rotation'])}, translation "
              f"{_n(fl['ratio_floor_translation'])})")
    print(f"advice took {out['timing_s']['total']:.1f} s")


def print_table(out: dict) -> None:
    print(f"advice for {out['scenario']} ({out['platform']}, {out['recorded_motions']} recorded "
          f"motions; {out['candidates']['feasible']} of {out['candidates']['drawn']} candidates "
          f"feasible)")
    _print_std_rows(out)
    for m in out["motions"]:
        cm = m["camera_motions"]
        desc = ", ".join(f"{c}: {v['angle_deg']:.1f} deg / "
                         f"{100 * math.hypot(*v['translation_m']):.1f} cm" for c, v in cm.items())
        joints = m.get("joint_targets_rad")
        jt = (" joints [deg] " + " ".join(f"{math.degrees(v):.1f}" for v in joints.values())
              if joints else f" cart {m['cart_pose']}")
        print(f"stop {m['step']}: {desc};{jt}")
    _print_notes(out)
    ver = out.get("verification")
    if ver:
        print("verification (dqopt; actual error vs truth, predicted largest 1-sigma):")
        print(f"{'':<12}{'rot [deg]':>10}{'trans [cm]':>12}{'σ rot [deg]':>13}{'σ trans [cm]':>14}")

        def vr(label, r):
            if not r.get("success"):
                print(f"{label:<12} FAILED: {r.get('error')}")
                return
            print(f"{label:<12}{r['rotation_error_deg']:>10.3f}{r['translation_error_cm']:>12.3f}"
                  f"{_n(r.get('max_std_deg')):>13}{_n(r.get('max_std_cm')):>14}")
        vr("baseline", ver["baseline"])
        vr("advised", ver["advised"])
        for r in ver.get("advised_seeds", []):
            vr(f"advised s{r['seed']}", r)
        for tag, key, name in BASELINES:
            for r in ver.get(key, []):
                vr(f"{tag} s{r['seed']}", r)
            med = ver.get(f"{key}_median") or {}
            if med:
                print(f"{tag + ' med':<12}{_n(med['rotation_error_deg']):>10}"
                      f"{_n(med['translation_error_cm']):>12}{_n(med['max_std_deg']):>13}"
                      f"{_n(med['max_std_cm']):>14}")
        for tag, key, name in BASELINES:
            rt = ver.get(f"ratio_advised_to_{key}_median") or {}
            if rt:
                print(f"advised median / {name} median: rotation "
                      f"{_n(rt['rotation_error_deg'])}, translation "
                      f"{_n(rt['translation_error_cm'])}")
        hs = ver.get("hindsight") or {}
        if hs:
            vr("hindsight", hs)
            rt = ver.get("ratio_hindsight_to_random_median") or {}
            print(f"hindsight (stops picked knowing the true X: a bound, not advice) / random "
                  f"median: rotation {_n(rt.get('rotation_error_deg'))}, translation "
                  f"{_n(rt.get('translation_error_cm'))}")
            rk = hs.get("ranking") or {}
            if rk:
                print(f"prediction vs actual over {rk['chains']} random chains of the "
                      f"candidates: rank correlation rotation "
                      f"{_n(rk['spearman_rotation'])}, translation "
                      f"{_n(rk['spearman_translation'])}; best-predicted tenth's actual "
                      f"error / all: {_n(rk['best_tenth_over_all_rotation'])}, "
                      f"{_n(rk['best_tenth_over_all_translation'])}")


#: (console tag, advice.json key, name) of the verification's random baselines
BASELINES = (("random", "random", "random (jog ranges)"),
             ("jog", "random_joint", "joint-jog"),
             ("wide", "random_wide", "random from the advice's candidates"))


def _n(v):
    return "inf/n/a" if v is None else f"{v:.3f}"


def print_recorded_table(out: dict) -> None:
    """Console summary of advice for recorded pose files."""
    print(f"advice for your pose files ({out['platform']}, {out['recorded_motions']} recorded "
          f"motions, {out['candidates']['drawn']} candidates)")
    _print_std_rows(out)
    for m in out["motions"]:
        desc = ", ".join(f"sensor {c}: {v['angle_deg']:.1f} deg about "
                         f"[{', '.join(f'{x:.2f}' for x in _axis(v))}] / "
                         f"{100 * math.hypot(*v['translation_m']):.1f} cm"
                         for c, v in m["sensor_motions"].items())
        print(f"stop {m['step']}: {desc}")
    print(f"not checked: {out['not_checked']}")
    _print_notes(out)


def _axis(v) -> list:
    n = math.hypot(*v["rotvec_deg"])
    return [x / n for x in v["rotvec_deg"]] if n > 0 else [0.0, 0.0, 0.0]


#: advice options that apply to recorded pose files (the others need a simulated scenario)
FILE_KEYS = ("k", "candidates", "max_rotation_deg", "max_translation_m", "recording", "force")


def parse_file_args(args):
    """``(CalibrateOptions, platform, advice options)`` for ``advise a=PATH ...``."""
    from simcalib.studies.advise.recorded import PLATFORMS
    from simcalib.pipeline.calibrate import parse_options
    opts = {"k": 5, "candidates": 1000, "recording": True, "force": True}
    platform, rest = None, []
    for a in args:
        key, eq, val = (x.strip() for x in a.partition("="))
        if eq and key == "platform":
            if val not in PLATFORMS:
                raise UsageError(f"platform must be one of {list(PLATFORMS)} for pose files; "
                                 f"received {val!r}")
            platform = val
        elif eq and key in ADVICE_KEYS:
            if key not in FILE_KEYS:
                raise UsageError(f"{key} needs a simulated scenario (scenario=NAME); with "
                                 f"pose files the advice options are {list(FILE_KEYS)}")
            opts[key] = _value(key, val)
        else:
            rest.append(a)
    if platform is None:
        raise UsageError(f"advice for pose files needs platform=... (one of "
                         f"{list(PLATFORMS)}: free = no platform model, cart = planar)")
    return parse_options(rest), platform, opts


def _prestart_recording(opts: dict) -> None:
    """rerun's import (the recording's worker) overlaps the advice."""
    if opts.get("recording", True):
        from simcalib.report.rerun.worker import prestart_worker
        prestart_worker()


def main_files(args: list[str]) -> int:
    """``advise a=PATH [b=PATH] platform=... output=DIR``: advice for recorded pose files."""
    import numpy as np

    from simcalib.studies.advise.recorded import advise_recorded, recorded_advice_dict
    from simcalib.pipeline.calibrate import calibrate
    from simcalib.solvers.kernels.mode import prepare_kernels
    copts, platform, opts = parse_file_args(args)
    _prestart_recording(opts)
    with prepare_kernels().context():
        r, assessment = calibrate(copts)
    mask = np.asarray(r.robust.inlier_mask, dtype=bool)
    kw = {k: opts[k] for k in ("max_rotation_deg", "max_translation_m") if k in opts}
    try:
        adv = advise_recorded(r.C[mask], r.H[mask], r.X, r.synced.T_a[-1], opts["k"],
                              platform=platform, rng=np.random.default_rng([copts.seed, 13]),
                              alpha=copts.alpha, n_candidates=opts["candidates"],
                              when_determined="advise" if opts["force"] else "stop",
                              passes=r.motions.passes, **kw)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    out = recorded_advice_dict(adv, {"a": str(copts.a), "b": str(copts.b) if copts.b else None,
                                     "calibration": assessment.verdict,
                                     "conventions": r.summary.get("conventions"),
                                     "inlier_motions": int(mask.sum())})
    out_dir = Path(copts.output)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "advice.json"
    if opts["recording"]:
        from simcalib.report.rerun.advice import record_recorded_advice
        out["recording"] = str(record_recorded_advice(out_dir / "advice.rrd", r.synced.T_a,
                                                      adv, out))
    path.write_text(json.dumps(out, indent=1, allow_nan=False))
    print_recorded_table(out)
    print(f"wrote {path}" + (f", {out['recording']}" if opts["recording"] else ""))
    return 0


@command('advise', summary='which motions to record next (verified in simulation)',
         usage='advise scenario=NAME|a=PATH b=PATH platform=P [k=5] output=DIR')
def main(args: list[str]) -> int:
    if any(a in ("-h", "--help") for a in args):
        print(USAGE, end="")
        return 0
    if any(a.partition("=")[0].strip() == "a" and "=" in a for a in args):
        return main_files(args)
    scenario, overrides, opts = parse_args(args)
    _prestart_recording(opts)
    from simcalib.pipeline.scenario import load_config
    cfg = load_config(scenario, list(overrides))
    from simcalib.studies.advise.advisor import check_advisable
    check_advisable(cfg)
    out_dir = Path(cfg.output) if cfg.output else Path("runs") / f"advise-{cfg.scenario}"
    out_dir.mkdir(parents=True, exist_ok=True)
    from simcalib.studies.advise import advice_dict, advise, baseline, verify
    from simcalib.studies.advise.advisor import choice_floor
    base = baseline(cfg)
    kw = {k: opts[k] for k in ("max_rotation_deg", "max_translation_m", "min_markers")
          if k in opts}
    adv = advise(base, opts["k"], seed=cfg.seed, n_candidates=opts["candidates"],
                 when_determined="advise" if opts.get("force", True) else "stop",
                 systematic=opts.get("systematic", True), **kw)
    ver = verify(base, adv, seeds=tuple(range(opts["seeds"])),
                 frames_per_stop=opts.get("stop_frames", 1),
                 hindsight=opts.get("hindsight", False)) if opts["verify"] else None
    floor = choice_floor(base, adv) if opts.get("floor", False) else None
    out = advice_dict(base, adv, ver, floor)
    path = out_dir / "advice.json"
    path.write_text(json.dumps(out, indent=1, allow_nan=False))
    if opts["recording"]:
        from simcalib.report.rerun.advice import record_advice
        out["recording"] = str(record_advice(out_dir / "advice.rrd", base, adv, out))
        path.write_text(json.dumps(out, indent=1, allow_nan=False))
    print_table(out)
    print(f"wrote {path}" + (f", {out['recording']}" if opts["recording"] else ""))
    return 0
