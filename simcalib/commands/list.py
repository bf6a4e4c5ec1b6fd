"""``simcalib list``: the scenario files (with their one-line description) and the
registered solvers. Imports neither MuJoCo, rerun nor OpenCV."""

from __future__ import annotations

from simcalib.cli import command
from simcalib.errors import UsageError

USAGE = """usage: python -m simcalib list

Lists the scenarios (scenarios/*.yaml or $SIMCALIB_SCENARIOS, with their one-line
description), the sweep files (scenarios/sweeps/) and the registered solvers.
"""


@command('list', summary='list scenarios and solvers',
         usage='list')
def main(args: list[str]) -> int:
    if any(a in ("-h", "--help") for a in args):
        print(USAGE, end="")
        return 0
    if args:
        raise UsageError(f"list takes no arguments; received {' '.join(args)}")
    from simcalib.pipeline.scenario import list_scenarios, scenario_dir
    from simcalib.solvers import registry
    scen = list_scenarios()
    print(f"scenarios ({scenario_dir()}):")
    width = max((len(n) for n in scen), default=0)
    for name, desc in scen.items():
        print(f"  {name:<{width}}  {desc}")
    if not scen:
        print("  (none)")
    from simcalib.studies.sweep.spec import list_sweeps, sweep_dir
    sweeps = list_sweeps()
    print(f"\nsweeps ({sweep_dir()}; simcalib sweep NAME output=DIR):")
    for name, desc in sweeps.items():
        print(f"  {name:<{width}}  {desc}")
    if not sweeps:
        print("  (none)")
    print("\nsolvers:")
    infos = registry.infos()
    width = max((len(i.name) for i in infos), default=0)
    for info in infos:
        tags = [info.family]
        if info.supports_prior:
            tags.append("prior")
        if info.certified:
            tags.append("certified")
        desc = info.description.strip().splitlines()[0] if info.description else ""
        print(f"  {info.name:<{width}}  [{', '.join(tags)}] {desc}")
    if not infos:
        print("  (none registered)")
    return 0
