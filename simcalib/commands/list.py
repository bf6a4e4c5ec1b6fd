"""``simcalib list``: the scenario files (with their one-line description), the registered
solvers and every other extension point's entries (pose sources, platforms and their
paths, pose-file formats, executors, experiments), each read from its registry. Imports
neither MuJoCo, rerun nor OpenCV."""

from __future__ import annotations

from simcalib.cli import command
from simcalib.errors import UsageError

USAGE = """usage: python -m simcalib list

Lists the scenarios (scenarios/*.yaml or $SIMCALIB_SCENARIOS, with their one-line
description), the sweep files (scenarios/sweeps/), the registered solvers, pose sources,
platforms (with the paths each drives), pose-file formats, executors and experiments.
"""


@command('list', summary='list scenarios, solvers and every registered extension',
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
    for title, rows in _extensions():
        print(f"\n{title}:")
        width = max((len(n) for n, _ in rows), default=0)
        for name, desc in rows:
            print(f"  {name:<{width}}  {desc}")
        if not rows:
            print("  (none registered)")
    return 0


def _extensions() -> list[tuple[str, list[tuple[str, str]]]]:
    """(title, [(name, one line)]) of each extension registry but the solvers."""
    from simcalib.executors import available as executors
    from simcalib.importers import FORMATS
    from simcalib.sources import available_sources
    from simcalib.studies.experiments import EXPERIMENTS
    from simcalib.world.paths import combinations
    from simcalib.world.platforms import available_platforms
    paths = combinations()
    return [
        ("pose sources (source=NAME, streams.a.source=NAME)",
         [(n, f"[{', '.join(i.kinds)}] {i.description}")
          for n, i in available_sources().items()]),
        ("platforms (world.platform=NAME; paths it drives)",
         [(n, f"[{', '.join(p for p, plats in paths.items() if n in plats)}] "
              f"{i.description}") for n, i in available_platforms().items()]),
        ("pose-file formats (calibrate a=FILE; detected, or format=NAME)",
         [(n, FORMATS.info(n)["description"]) for n in sorted(FORMATS.names())]),
        ("executors (sweep executor=NAME)",
         [(n, i.description + (f" [{i.extra}]" if i.extra else ""))
          for n, i in executors().items()]),
        ("experiments (experiment NAME)",
         [(n, EXPERIMENTS.info(n).description) for n in EXPERIMENTS.names()]),
    ]
