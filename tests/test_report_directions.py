"""One source of truth per quantity (simcalib.report.directions): every scenario's console,
results.json and recording summary, and a calibration's calibration.json, console report
and recording summary say the same of each flagged direction (its state and 1-sigma in
words), of each sigma and of the determined error — "—" exactly where the JSON has null."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from rrd_reading import chunks
from simcalib.cli import main
from simcalib.pipeline.scenario import list_scenarios, load_config
from simcalib.report.directions import NOT_MEASURED

#: short runs: every scenario in a few seconds (rendered ones at 5 fps), pairing relaxed so
#: that the short paths still give motions
SHORT = ("world.duration_s=4", "world.fps=5", "synthetic.num_motions=60",
         "pairing.n_pairs=30", "pairing.max_translation_m=1.0", "pairing.max_rotation_deg=90",
         "progress=false", "workers=1")


def _renders(name: str) -> bool:
    from simcalib.sources import get_source
    cfg = load_config(name, list(SHORT))
    return any(get_source(s).info.renders for s in {cfg.source, cfg.streams.a.source,
                                                    cfg.streams.b.source} if s)


def _params():
    out = []
    for name in list_scenarios():
        marks = [] if load_config(name).kind == "synthetic" else [pytest.mark.slow]
        out.append(pytest.param(name, marks=marks, id=name))
    return out


def _cells(line: str, sep: str) -> list[str]:
    return [c.strip() for c in line.strip().strip(sep).split(sep)]


def _console_rows(text: str, labels) -> dict:
    """label -> the console row's cells (split on runs of 2+ spaces) or ``FAILED: ...``."""
    out = {}
    for ln in text.splitlines():
        for label in labels:
            if ln.startswith(label + " ") and label not in out:
                rest = ln[len(label):].strip()
                out[label] = rest if rest.startswith("FAILED:") else re.split(r"\s{2,}", rest)
    return out


def _summary_rows(md: str, labels) -> dict:
    """label -> the summary table row's cells (without the label) and its verdict (the
    ``verdict [labels]: **cell**`` line naming it), or ``FAILED``."""
    out, verdict = {}, {}
    for ln in md.splitlines():
        cells = _cells(ln, "|") if ln.startswith("|") else []
        if cells and cells[0].strip("*") in labels:
            out[cells[0].strip("*")] = "FAILED" if "FAILED" in ln else cells[1:]
        m = re.match(r"- verdict \[([^\]]*)\]: \*\*(.*)\*\*$", ln)
        if m:
            verdict.update({lb: m.group(2) for lb in m.group(1).split(", ")})
    return {lb: c if c == "FAILED" else [*c, verdict.get(lb)] for lb, c in out.items()}


def _close(text: str, value, scale: float) -> bool:
    """Whether the number printed in ``text`` is ``value`` x ``scale`` to its rounding."""
    printed = float(text)
    digits = len(text.split(".")[1].split("e")[0]) if "." in text else 0
    tol = abs(printed) * 1e-2 if "e" in text else 0.51 * 10 ** -digits
    return abs(printed - value * scale) <= tol + 1e-12


def _check_pm(cell: str, err, sigma, scale: float, what: str) -> None:
    e, _, s = cell.partition(" ± ")
    assert _close(e, err, scale), (what, cell, err)
    if sigma is None:
        assert s == NOT_MEASURED, (what, cell)
    else:
        assert _close(s, sigma, scale), (what, cell, sigma)


def _check_states(cell: str, dirs: list, what: str) -> None:
    """The verdict cell names only states the JSON gives, worst first, with their tags."""
    shown = {}
    for part in cell.split("; "):
        state, _, tags = part.partition(": ")
        shown[state] = re.sub(r", \+\d+$", "", tags)
    states = {d["state"] for d in dirs}
    assert set(shown) <= states, (what, cell, states)
    if "+" not in cell:
        assert set(shown) == states, (what, cell, states)


def _check_solver(label: str, s: dict, console_row, summary_row, console: str, md: str):
    if s["X"] is None:
        assert isinstance(console_row, str) and console_row.startswith("FAILED:"), label
        assert summary_row == "FAILED", label
        return
    _, rot, tr, det, _, cell = console_row
    assert summary_row[0] == rot and summary_row[2] == tr and summary_row[4] == det, \
        (label, console_row, summary_row)
    assert summary_row[5] == cell, (label, cell, summary_row[5])
    _check_pm(rot, s["rotation_error_deg"], s["sigma_rotation_deg"], 1.0, label)
    _check_pm(tr, s["translation_error_m"], s["sigma_translation_m"], 100.0, label)
    assert (s["sigma_rotation_deg"] is None) == bool(s["sigma_rotation_reason"]), label
    assert (s["sigma_translation_m"] is None) == bool(s["sigma_translation_reason"]), label
    det_m = s["translation_error_determined_m"]
    assert (det == NOT_MEASURED) == (det_m is None), (label, det, det_m)
    if det_m is not None:
        assert _close(det, det_m, 100.0), (label, det, det_m)
    dirs = s["undetermined_directions"]
    words = [f"{d['description']}: {d['state']} ({d['sigma']})" for d in dirs]
    assert s["verdict"]["directions"] == words, label
    for w in words:                              # the same sentence everywhere
        assert w in console and w in md, (label, w)
    if dirs:
        _check_states(cell, dirs, label)
    else:
        assert cell == s["verdict"]["verdict"], (label, cell)


@pytest.mark.parametrize("name", _params())
def test_console_results_and_summary_agree(name, tmp_path, capsys, request):
    if _renders(name):
        request.getfixturevalue("gl")    # skips, naming why, where no backend exists
    out = tmp_path / name
    assert main(["run", f"scenario={name}", f"output={out}", *SHORT]) == 0
    console = capsys.readouterr().out
    res = json.loads((out / "results.json").read_text())
    md = str(np.ravel(chunks(out / "recording.rrd")["/summary"]["TextDocument:text"])[0])
    labels = list(res["solvers"])
    crow, srow = _console_rows(console, labels), _summary_rows(md, labels)
    assert set(crow) == set(srow) == set(labels), (crow, srow)
    for label, s in res["solvers"].items():
        _check_solver(label, s, crow[label], srow[label], console, md)
    for note in [ln for ln in console.splitlines() if ln.startswith(NOT_MEASURED)]:
        assert note in md, note                  # the footnotes of every "—"


# ---------------------------------------------------------------------------- calibrate
def _sigma_numbers(line: str) -> list[str]:
    """The per-axis entries of a sigma line: ``[a, b, c]`` twice (rotation, translation)."""
    return [x.strip() for grp in re.findall(r"\[([^\]]*)\]", line) for x in grp.split(",")]


@pytest.mark.slow
@pytest.mark.parametrize("path, prior", [("3d", False), ("planar", False), ("planar", True)])
def test_calibration_json_console_and_summary_agree(path, prior, tmp_path, capsys):
    """A determined 3-D rig, a planar one (vertical translation undetermined: no finite
    1-sigma on that axis) and the planar one with a prior: the verdict line, each
    direction's words and every axis' 1-sigma read the same in calibration.json, the
    console report and the recording's summary pane."""
    from simcalib.report.results import write_tum
    from simcalib.world.stream_sim import rig_streams
    s = rig_streams(path=path, duration_s=12.0, rng=np.random.default_rng(3))
    write_tum(tmp_path / "a.txt", s.t_a, s.T_a)
    write_tum(tmp_path / "b.txt", s.t_b, s.T_b)
    args = ["calibrate", f"a={tmp_path / 'a.txt'}", f"b={tmp_path / 'b.txt'}",
            f"output={tmp_path / 'out'}"]
    if prior:
        q = __import__("simcalib.geometry", fromlist=["x"]).quat_from_matrix(s.X[:3, :3])
        args.append("prior=[" + ",".join(f"{v:.6f}" for v in [*s.X[:3, 3], *q]) + "]")
    code = main(args)
    console = capsys.readouterr().out
    rep = json.loads((tmp_path / "out" / "calibration.json").read_text())
    assert code == rep["exit_code"]
    md = str(np.ravel(chunks(tmp_path / "out" / "recording.rrd")["/summary"][
        "TextDocument:text"])[0])
    v, u = rep["verdict"], rep["uncertainty"]
    words = [f"{d['description']}: {d['state']} ({d['sigma']})"
             for d in v["direction_details"]]
    assert v["directions"] == words
    verdict = f"verdict: {v['verdict'].upper()}" + (f" - {v['message']}" if v["message"]
                                                   else "")
    assert verdict in console.splitlines()
    assert verdict in [ln[2:].replace("**", "") for ln in md.splitlines()]
    for w in words:
        assert w in console and w in md, w
    sig_c = next(ln for ln in console.splitlines() if ln.startswith("uncertainty (1 sigma"))
    sig_m = next(ln for ln in md.splitlines() if ln.startswith("- uncertainty (1 sigma"))
    assert sig_c.startswith(sig_m[2:]), (sig_c, sig_m)
    expected = [(x, 1.0) for x in u["std_rotation_deg"]] + [
        (x, 1e3) for x in u["std_translation_m"]]
    for text, (x, scale) in zip(_sigma_numbers(sig_m), expected, strict=True):
        assert (text == NOT_MEASURED) == (x is None), (text, x)
        if x is not None:
            assert _close(text, x, scale), (text, x)
    assert (u["std_reason"] is not None) == (None in u["std_rotation_deg"]
                                             + u["std_translation_m"])
    if path == "planar" and not prior:
        assert u["std_reason"] and any(d["state"] == "undetermined"
                                       for d in v["direction_details"])
