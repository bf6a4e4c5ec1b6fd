"""``simcalib advise scenario=NAME [k=5] [verify=true] [output=DIR] [key=value ...]``:
which motions to record next (docs/advice.md)."""

from __future__ import annotations

import math
from pathlib import Path

from simcalib.cli import command
from simcalib.errors import SimcalibError, UsageError

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
prints the predicted 1-sigma per axis before and after each motion, and each stop as the
motion from the previous stop (the first from the reference: the run's last pose). A
platform moves as it can: an arm about any axis, an arm standing in for a SCARA
(world.arm.motions=scara, scenario scara) and a cart about the vertical only; what no
such motion determines is stated (cannot help) and left out of the choice.

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
    from simcalib.studies.advise.console import recorded_advice_lines
    from simcalib.studies.advise.session import files_session
    copts, platform, opts = parse_file_args(args)
    _prestart_recording(opts)
    ranges = {k: opts[k] for k in ("max_rotation_deg", "max_translation_m") if k in opts}
    try:
        out = files_session(copts, platform, k=opts["k"], n_candidates=opts["candidates"],
                            force=opts["force"], recording=opts["recording"], **ranges)
    except SimcalibError:   # its own exit code (bad pose files: 3, like calibrate)
        raise
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    print("\n".join(recorded_advice_lines(out)))
    print(f"wrote {Path(copts.output) / 'advice.json'}"
          + (f", {out['recording']}" if opts["recording"] else ""))
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
    from simcalib.studies.advise.advisor import check_advisable
    from simcalib.studies.advise.console import advice_lines
    from simcalib.studies.advise.session import scenario_session
    cfg = load_config(scenario, list(overrides))
    check_advisable(cfg)
    out_dir = Path(cfg.output) if cfg.output else Path("runs") / f"advise-{cfg.scenario}"
    ranges = {k: opts[k] for k in ("max_rotation_deg", "max_translation_m", "min_markers")
              if k in opts}
    out = scenario_session(cfg, out_dir, k=opts["k"], n_candidates=opts["candidates"],
                           force=opts.get("force", True),
                           systematic=opts.get("systematic", True), verify=opts["verify"],
                           seeds=opts["seeds"], stop_frames=opts.get("stop_frames", 1),
                           hindsight=opts.get("hindsight", False),
                           floor=opts.get("floor", False), recording=opts["recording"],
                           **ranges)
    print("\n".join(advice_lines(out)))
    print(f"wrote {out_dir / 'advice.json'}"
          + (f", {out['recording']}" if opts["recording"] else ""))
    return 0
