"""``simcalib sweep FILE [key=value ...] [executor=NAME] [workers=N] [address=...]
output=DIR``; ``simcalib sweep report DIR``; ``simcalib sweep status DIR``."""

from __future__ import annotations

from simcalib.cli import command
from simcalib.errors import UsageError

USAGE = """usage: python -m simcalib sweep FILE [key=value ...] [executor=NAME] [workers=N]
                                   [address=auto|ray://host:port] [seeds=N] output=DIR
       python -m simcalib sweep report DIR      # rebuild results.parquet and report.md
       python -m simcalib sweep status DIR      # cells done / failed / remaining
       python -m simcalib sweep list            # shipped sweep files

FILE is a shipped sweep name ({sweeps}) or a YAML path (format: docs/sweep.md).
Other key=value pairs are run-config overrides applied to every cell (checked for every
cell before any work). executor=local (default) runs a process pool on this machine
(workers = its cores by default); executor=ray runs Ray tasks on a local Ray instance, or
on a cluster with address=auto / address=ray://host:port (pip install -e '.[cluster]').
Executors: {executors}.
Re-running into the same output skips finished cells. Options: --quiet (no progress).
"""

_OWN = ("executor", "workers", "address", "output", "seeds", "seed")


@command('sweep', summary='run a study of many runs (grid / zip / random axes x seeds)',
         usage='sweep FILE [key=value ...] output=DIR | sweep report|status DIR')
def main(args: list[str]) -> int:
    from simcalib.studies.sweep import list_sweeps
    if not args or args[0] in ("-h", "--help"):
        from simcalib.executors import available as executors
        print(USAGE.format(sweeps=", ".join(list_sweeps()) or "none",
                           executors="; ".join(f"{n} ({i.description})"
                                               for n, i in executors().items())), end="")
        return 0 if args else 2
    if args[0] == "list":
        for name, desc in list_sweeps().items():
            print(f"  {name:<10} {desc}")
        return 0
    if args[0] in ("report", "status"):
        if len(args) != 2:
            raise UsageError(f"sweep {args[0]} takes one directory; received {args[1:]}")
        return _report(args[1]) if args[0] == "report" else _status(args[1])
    return _run(args)


def _parse(args: list[str]):
    from simcalib.config.engine import parse_override
    from simcalib.config.checks import check_int
    flags = {a for a in args if a.startswith("--")}
    if flags - {"--quiet"}:
        raise UsageError(f"unknown option {sorted(flags - {'--quiet'})[0]!r}; options: --quiet")
    words = [a for a in args if not a.startswith("--")]
    if not words or "=" in words[0]:
        raise UsageError("sweep needs a sweep FILE (name or YAML path) first; see sweep --help")
    own, overrides = {}, {}
    for item in words[1:]:
        key, raw = parse_override(item)
        if key in _OWN:
            own[key] = raw
        else:
            import yaml
            overrides[key] = yaml.safe_load(raw) if raw.strip() else raw
    if "output" not in own:
        raise UsageError("sweep needs output=DIR (where cells, table and report go)")
    if "workers" in own:
        own["workers"] = check_int("workers", _int(own["workers"], "workers"), lo=1)
    for k in ("seeds", "seed"):
        if k in own:
            overrides[k] = _int(own.pop(k), k)
    return words[0], own, overrides, "--quiet" not in flags


def _int(raw, key):
    try:
        return int(raw)
    except (TypeError, ValueError):
        from simcalib.errors import ConfigError
        raise ConfigError(key=key, value=raw, allowed="an integer") from None


def _run(args: list[str]) -> int:
    from simcalib.studies.sweep import load_sweep, run_sweep
    name, own, overrides, progress = _parse(args)
    spec = load_sweep(name, overrides)
    summary = run_sweep(spec, own["output"], executor=own.get("executor", "local"),
                        workers=own.get("workers"), address=own.get("address"),
                        progress=progress)
    over = summary.overhead_fraction
    print(f"sweep {spec.name}: {summary.cells} cells ({summary.skipped} already done, "
          f"{summary.ran} run, {summary.failed} failed) in {summary.wall_s:.1f} s with "
          f"executor={summary.executor}"
          + (f"; overhead {over:.1%} of worker time" if over is not None else ""))
    print(f"wrote {summary.output}/results.parquet, report.md")
    return 0


def _report(out: str) -> int:
    from simcalib.studies.sweep import store
    from simcalib.studies.sweep.report import write_report
    store.write_table(out)
    print(f"wrote {store.write_table(out)}, {write_report(out)}")
    return 0


def _status(out: str) -> int:
    from simcalib.studies.sweep import status
    st = status(out)
    print(f"{st['output']}: {st['done']}/{st['cells']} cells done, {st['failed']} failed, "
          f"{st['remaining']} remaining"
          + (f"; mean cell {st['cell_s_mean']:.2f} s" if st['cell_s_mean'] else ""))
    for c in st["failed_cells"]:
        err = c["error"] or {}
        print(f"  failed cell {c['index']} ({c['key']}): {err.get('type')}: "
              f"{err.get('message')}")
    return 0
