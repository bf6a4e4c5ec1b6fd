"""``simcalib calibrate a=PATH b=PATH output=DIR [key=value ...]``: calibrate ``X = T_a_b``
from two recorded pose files or a ROS bag (docs/calibrate.md).

A thin layer over :mod:`simcalib.pipeline.calibrate` (the library: options, the one
estimation path, the assessment, the outputs): it parses, prints and returns the exit code.

Exit status: 0 determined, 6 degenerate or implausible (the outputs are still written, but
for a rig that does not rotate at all: no X), 5
the solver failed, 3 bad data (``DataError``), 2 bad options.
"""

from __future__ import annotations

from pathlib import Path

from simcalib.cli import command
from simcalib.errors import UsageError

__all__ = ["main", "help_text"]

# ------------------------------------------------------------------------------ command
USAGE = """usage: python -m simcalib calibrate a=PATH b=PATH output=DIR [key=value ...]

Calibrates X = T_a_b (pose of sensor b in sensor a) from two recorded pose files: reads
them (format detected or named), decides which reading makes them consistent (inverse
poses, quaternion order), estimates the clock offset, pairs the poses into motions,
rejects outlier motions and solves. Prints X, its uncertainty, the verdict on degeneracy,
the offset, inliers, residuals and the conventions used; writes calibration.json,
motions.npz and recording.rrd (open with `rerun recording.rrd`) into output.

formats: {formats}

keys (type = default):
{keys}

exit status: 0 determined, 6 degenerate or implausible (outputs written; none when neither
stream rotates), 5 solver failed, 3 bad data, 2 bad options.
"""


def help_text() -> str:
    from simcalib.importers import available
    from simcalib.pipeline.calibrate import CalibrateOptions
    from simcalib.pipeline.scenario import describe_keys
    return USAGE.format(formats=", ".join(available()),
                        keys="\n".join(describe_keys(CalibrateOptions)))


def _recording_off(args) -> bool:
    """Whether the arguments turn the recording off (read before they are parsed: the
    recording worker starts first; a worker started for nothing is stopped)."""
    return any(a.replace(" ", "").lower() in ("recording=false", "recording=0", "recording=no",
                                              "recording=off") for a in args)


@command('calibrate', summary='calibrate X from two recorded pose files (offset, outliers)',
         usage='calibrate a=PATH b=PATH output=DIR [key=value ...]',
         quick_exit=True)      # every output is closed when main returns
def main(args: list[str]) -> int:
    if any(a in ("-h", "--help") for a in args):
        print(help_text(), end="")
        return 0
    if not args:
        raise UsageError("calibrate needs a=PATH b=PATH output=DIR (see calibrate --help)")
    listing = [x for x in args if x.startswith("list_bag=")]
    if listing:
        from simcalib.ros.bag import list_bag
        if len(args) != 1:
            raise UsageError(f"list_bag=FILE takes no other keys; received {args}")
        print(list_bag(listing[0].split("=", 1)[1]), end="")
        return 0
    if not _recording_off(args):   # rerun's import (0.4-1 s) overlaps everything else,
        from simcalib.report.rerun.worker import prestart_worker   # parsing included
        prestart_worker()
    from simcalib.pipeline.calibrate import calibrate, parse_options, write_outputs
    from simcalib.report.calibration import format_report
    from simcalib.report.outputs import check_output_dir
    opts = parse_options(args)
    check_output_dir(opts.output, opts.overwrite)   # exit 2, before any work
    if not opts.recording:
        from simcalib.report.rerun.worker import cancel_prestarted_worker
        cancel_prestarted_worker()
    from simcalib.solvers.kernels.mode import INTERPRETED_NOTE, prepare_kernels
    plan = prepare_kernels()        # the first use on an installation: interpreted kernels
    with plan.context():            # (the report's diagnostics may solve too)
        r, a = calibrate(opts)
        report = write_outputs(opts, r, a, solver_kernels=plan.mode)
        text = format_report(report)
    print(text)
    if plan.mode == "interpreted":
        print(INTERPRETED_NOTE)
    print(f"written: {Path(opts.output) / 'calibration.json'}, motions.npz"
          + (", recording.rrd" if opts.recording else "")
          + "".join(f", {n}" for n in report["files"].get("exports", {}).values()))
    return a.exit_code
