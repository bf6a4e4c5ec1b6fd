"""The table of every shipped scenario's default run (docs/results-schema.md):
``python -m simcalib.studies.experiments.scenarios_table [--markdown] [NAME ...]``.

Runs each scenario with no overrides (seed 0, the recording on, as a user would) into a
temporary directory and prints the wall time of the run and, for dqopt, daniilidis and
dqopt+prior: rotation / translation error (determined part), and dqopt's verdict.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path


def _cell(s: dict | None) -> str:
    if not s:
        return "–"
    if s.get("X") is None:
        return "FAILED"
    det = s.get("translation_error_determined_m")
    tr = s["translation_error_m"]
    text = f"{s['rotation_error_deg']:.3g}° / {_length(tr)}"
    if det is not None and abs(det - tr) > 1e-6:
        text += f" ({_length(det)})"
    return text


def _length(m: float) -> str:
    return f"{m:.3g} m" if m >= 10 else f"{100 * m:.3g} cm"


def _verdict(s: dict | None) -> str:
    if not s or s.get("X") is None:
        return "–"
    v = s.get("verdict") or {}
    word = v.get("verdict", "?") if isinstance(v, dict) else str(v)
    dirs = list(v.get("directions") or []) if isinstance(v, dict) else []
    return word + (f": {'; '.join(str(d).split(' (camera-a frame)')[0] for d in dirs[:2])}"
                   + (f" (+{len(dirs) - 2})" if len(dirs) > 2 else "") if dirs else "")


def rows(names) -> list[dict]:
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import run
    out = []
    for name in names:
        with tempfile.TemporaryDirectory(prefix=f"scen-{name}-") as tmp:
            cfg = load_config(name, [f"output={Path(tmp) / name}", "progress=false"])
            t0 = time.perf_counter()
            res = run(cfg, echo=False)
            wall = time.perf_counter() - t0
            doc = json.loads(Path(res.results_path).read_text())
        sv = doc["solvers"]
        out.append({"scenario": name, "source": doc.get("source"), "wall_s": wall,
                    "dqopt": _cell(sv.get("dqopt")), "daniilidis": _cell(sv.get("daniilidis")),
                    "prior": _cell(sv.get("dqopt+prior")), "verdict": _verdict(sv.get("dqopt"))})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.scenarios_table",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="scenarios (default: every shipped one)")
    args = ap.parse_args(argv)
    from simcalib.pipeline.scenario import list_scenarios
    names = args.names or list(list_scenarios())
    print("| scenario | source | wall [s] | dqopt rot / trans (determined) | daniilidis | "
          "dqopt+prior | dqopt verdict |")
    print("|---|---|---|---|---|---|---|")
    for r in rows(names):
        print(f"| `{r['scenario']}` | {r['source']} | {r['wall_s']:.1f} | {r['dqopt']} | "
              f"{r['daniilidis']} | {r['prior']} | {r['verdict']} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
