"""``simcalib run scenario=NAME [key=value ...]``: one end-to-end run.

The configuration is resolved and validated completely (:func:`simcalib.pipeline.scenario.load_config`)
before any work; a :class:`~simcalib.errors.ConfigError` ends the command with exit code 2.
"""

from __future__ import annotations

from simcalib.cli import command
from simcalib.errors import UsageError

USAGE = """usage: python -m simcalib run scenario=NAME [key=value ...] [--dry-run] [--debug]

Runs one scenario end to end: world -> pose streams -> relative motions (pairing,
appendix D.1 pre-filter) -> every solver -> errors against the true extrinsic X. Writes
into the run directory (output=DIR, default runs/<scenario>-<timestamp>): results.json,
config.yaml, extrinsics.json, TUM trajectories (tum/), recording.rrd (open with
`rerun recording.rrd`), and prints a summary table.

Overrides are dotted keys with typed values (YAML syntax for numbers, booleans; lists
in brackets):
  seed=3 output=runs/x noise.sigma_r_deg=1.0 solvers=[dqopt,daniilidis] source=noisy
  alpha=0.5 alpha=[0.1,1,10] camera.width=1280
A key may be shortened to a unique suffix of its full path (camera.width sets both
cameras). Every key and value is checked before any work (exit code 2).

options:
  --dry-run     resolve and print the configuration, run nothing
  --debug       on failure, show the full Python traceback (also --traceback)

scenarios: {scenarios}

keys (type = default):
{keys}
"""

OPTIONS = ("--dry-run",)


def help_text() -> str:
    from simcalib.pipeline.scenario import describe_keys, list_scenarios
    scen = ", ".join(list_scenarios()) or "(none found)"
    return USAGE.format(scenarios=scen, keys="\n".join(describe_keys()))


def parse_args(args: list[str]) -> tuple[str, list[str], set[str]]:
    """``(scenario, overrides, flags)`` from the command line (``run planar`` is
    ``run scenario=planar``)."""
    flags = {a for a in args if a.startswith("--")}
    unknown = sorted(flags - set(OPTIONS))
    if unknown:
        raise UsageError(f"unknown option {unknown[0]!r}; options: "
                         f"{', '.join(OPTIONS)}, --debug, --help")
    scenario = None
    overrides = []
    for i, a in enumerate(x for x in args if not x.startswith("--")):
        if "=" not in a:
            if i == 0:
                scenario = a
                continue
            raise UsageError(f"expected key=value, received {a!r} (see run --help)")
        key, value = a.split("=", 1)
        if key.strip() == "scenario":
            if scenario is not None:
                raise UsageError("scenario given twice")
            scenario = value.strip()
        else:
            overrides.append(a)
    if not scenario:
        from simcalib.pipeline.scenario import list_scenarios
        raise UsageError("run needs scenario=NAME; available: "
                         f"{', '.join(list_scenarios()) or '(none)'}")
    return scenario, overrides, flags


@command('run', summary='simulate, pair, solve and evaluate one scenario',
         usage='run scenario=NAME [key=value ...] [--dry-run]')
def main(args: list[str]) -> int:
    if any(a in ("-h", "--help") for a in args):
        print(help_text(), end="")
        return 0
    scenario, overrides, flags = parse_args(args)
    if "--dry-run" not in flags:   # rerun's import overlaps loading the configuration too
        from simcalib.report.rerun.worker import prestart_worker
        prestart_worker()
    from simcalib.pipeline.scenario import load_config
    from simcalib.config.engine import to_dict
    cfg = load_config(scenario, overrides)        # ConfigError -> exit 2, nothing done
    if "--dry-run" in flags:
        import yaml
        print(yaml.safe_dump(to_dict(cfg), sort_keys=False), end="")
        return 0
    from simcalib.pipeline.stages import run
    result = run(cfg)                             # RunInterrupted -> 130 (cli.main)
    print(f"results: {result.output_dir}")
    return 0
