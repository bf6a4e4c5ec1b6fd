"""Sweeps: expansion and validation, seeds, resumption, executors, report, CLI."""

import json
import shutil

import pytest

from simcalib.errors import ConfigError
from simcalib.executors import available as available_executors
from simcalib.studies.sweep import expand, load_sweep, run_sweep, status
from simcalib.studies.sweep import store

SMALL = {
    "description": "tiny synthetic sweep for tests",
    "base": "random",
    "seed": 7,
    "seeds": 2,
    "set": {"solvers": ["dqopt", "daniilidis"], "synthetic.num_motions": 60,
            "pairing.n_pairs": 20},
    "grid": {"noise.sigma_r_deg": [0.1, 1.0]},
}

TIMING = ("cell_s", "run_s", "runtime_s")


def _rows(out):
    rows = store.table(out)
    return [{k: v for k, v in r.items() if k not in TIMING} for r in rows]


def test_expansion_counts_blocks_and_seeds():
    spec = load_sweep({**SMALL, "zip": {"noise.sigma_t_m": [0.001, 0.01, 0.1],
                                        "pairing.n_pairs": [10, 20, 30]},
                       "random": {"samples": 4, "keys": {
                           "alpha": {"distribution": "loguniform", "low": 0.1, "high": 10},
                           "pairing.step": {"distribution": "choice", "values": [1, 2]}}},
                       "set": {"solvers": ["dqopt"]}})
    cells = expand(spec)
    assert len(cells) == 2 * 3 * 4 * 2
    assert spec.axes == ("noise.sigma_r_deg", "noise.sigma_t_m", "pairing.n_pairs", "alpha",
                         "pairing.step")
    # zipped keys advance together
    assert {(c.values["noise.sigma_t_m"], c.values["pairing.n_pairs"]) for c in cells} == {
        (0.001, 10), (0.01, 20), (0.1, 30)}
    alphas = {c.values["alpha"] for c in cells}
    assert len(alphas) == 4 and all(0.1 <= a <= 10 for a in alphas)
    # the seed depends on the values and the replicate, not on the position
    again = expand(load_sweep({**SMALL, "grid": {"noise.sigma_r_deg": [1.0, 0.1]}}))
    first = expand(load_sweep(SMALL))
    by_val = lambda cs: {(c.values["noise.sigma_r_deg"], c.replicate): c.seed for c in cs}
    assert by_val(again) == by_val(first)
    assert len(set(by_val(first).values())) == 4
    # another sweep seed, other run seeds
    other = expand(load_sweep({**SMALL, "seed": 8}))
    assert set(by_val(other).values()).isdisjoint(by_val(first).values())


@pytest.mark.parametrize("bad, words", [
    ({"grid": {"noise.sigma_r_dg": [0.1]}}, "sigma_r_deg"),
    ({"grid": {"noise.sigma_r_deg": [0.1, -1.0]}}, "sigma_r_deg"),
    ({"zip": {"alpha": [1, 2], "pairing.n_pairs": [10]}}, "one length"),
    ({"random": {"samples": 2, "keys": {"alpha": {"distribution": "gauss"}}}}, "normal"),
    ({"random": {"samples": 2, "keys": {"alpha": {"distribution": "uniform", "low": 2,
                                                  "high": 1}}}}, "low < high"),
    ({"grdi": {"alpha": [1]}}, "grid"),
    ({"grid": {"alpha": []}}, "empty"),
    ({"set": {"alpha": 1}, "grid": {"alpha": [1, 2]}}, "more than one"),
])
def test_bad_sweeps_fail_before_any_work(bad, words, tmp_path):
    with pytest.raises(ConfigError, match=words):
        spec = load_sweep({**SMALL, **bad})
        run_sweep(spec, tmp_path / "out", progress=False)
    assert not (tmp_path / "out" / "cells").exists()


def test_unknown_sweep_name_lists_shipped_ones():
    with pytest.raises(ConfigError, match="noise"):
        load_sweep("noize")


@pytest.mark.slow
def test_shipped_sweeps_expand_and_validate(tmp_path):
    from simcalib.studies.sweep.cells import resolve_cells
    from simcalib.studies.sweep.spec import list_sweeps
    names = list_sweeps()
    assert {"noise", "paths", "vision", "motions"} <= set(names)
    for name in names:
        spec = load_sweep(name)
        cells = expand(spec)
        resolved = resolve_cells(spec, cells, output=tmp_path)
        assert len({c.key for c, _ in resolved}) == len(cells), name
    assert len(expand(load_sweep("noise"))) == 200


@pytest.mark.slow
def test_local_sweep_resumes_and_reports(tmp_path):
    out = tmp_path / "sw"
    spec = load_sweep(SMALL)
    s1 = run_sweep(spec, out, workers=2, progress=False)
    assert (s1.cells, s1.ran, s1.skipped, s1.failed) == (4, 4, 0, 0)
    rows = _rows(out)
    assert len(rows) == 4 * 2 and {r["solver"] for r in rows} == {"dqopt", "daniilidis"}
    assert all(r["rotation_error_deg"] is not None for r in rows)
    assert all(r["sigma_rotation_deg"] > 0 and r["verdict"] == "determined" for r in rows)
    assert (out / "results.parquet").is_file() and (out / "report.md").is_file()
    assert (out / "report.rrd").stat().st_size > 1000
    report = (out / "report.md").read_text()
    assert "daniilidis vs dqopt" in report and "noise.sigma_r_deg" in report
    import pyarrow.parquet as pq
    t = pq.read_table(out / "results.parquet")
    assert t.num_rows == 8 and "noise.sigma_r_deg" in t.column_names
    # a killed sweep: two cells never finished -> only they run again, same table
    cells = sorted((out / "cells").glob("*.json"))
    for p in cells[:2]:
        p.unlink()
    assert status(out)["remaining"] == 2
    s2 = run_sweep(spec, out, workers=1, progress=False)
    assert (s2.ran, s2.skipped) == (2, 2)
    assert _rows(out) == rows


@pytest.mark.slow
def test_failed_cell_is_recorded_and_does_not_sink_the_sweep(tmp_path):
    # 30 pairs from a data set of 20 motions fails inside the run, not in validation
    spec = load_sweep({**SMALL, "seeds": 1, "grid": {"pairing.n_pairs": [10, 30]},
                       "set": {"solvers": ["dqopt"], "synthetic.num_motions": 20}})
    s = run_sweep(spec, tmp_path / "f", workers=1, progress=False)
    assert (s.ran, s.failed) == (2, 1)
    st = status(tmp_path / "f")
    assert st["failed"] == 1 and "n_pairs" in st["failed_cells"][0]["error"]["message"]
    assert "Failed cells" in (tmp_path / "f" / "report.md").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in available_executors() if n != "local"])
def test_executors_and_worker_counts_give_identical_tables(tmp_path, name):
    import importlib.util
    extra = available_executors()[name].extra
    if extra and importlib.util.find_spec(name) is None:
        pytest.skip(f"executor={name} needs the [{extra}] extra")
    spec = load_sweep(SMALL)
    run_sweep(spec, tmp_path / "w1", workers=1, progress=False, report=False)
    run_sweep(spec, tmp_path / name, executor=name, workers=2, progress=False,
              report=False)
    a, b = _rows(tmp_path / "w1"), _rows(tmp_path / name)
    assert a == b and len(a) == 8


@pytest.mark.slow
def test_sweep_cli(tmp_path, capsys):
    from simcalib.cli import main
    f = tmp_path / "s.yaml"
    import yaml
    f.write_text(yaml.safe_dump({**SMALL, "seeds": 1}))
    out = tmp_path / "cli"
    assert main(["sweep", str(f), f"output={out}", "workers=1", "--quiet"]) == 0
    assert "2 cells" in capsys.readouterr().out
    assert main(["sweep", "status", str(out)]) == 0
    assert "2/2 cells done" in capsys.readouterr().out
    assert main(["sweep", "report", str(out)]) == 0
    capsys.readouterr()
    assert main(["sweep", str(f), f"output={tmp_path / 'x'}", "executor=dask"]) == 2
    err = capsys.readouterr().err
    assert "unknown executor 'dask'" in err and ", ".join(available_executors()) in err
    assert main(["sweep", str(f)]) == 2          # no output
    assert main(["sweep", "status", str(tmp_path)]) == 3  # not a sweep directory


def test_misspelled_key_is_reported_once_before_any_cell(tmp_path, capsys):
    from simcalib.cli import main
    out = tmp_path / "typo"
    assert main(["sweep", "noise", "sigma_r_dg=1", f"output={out}", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("sigma_r_dg") == 1 and "did you mean 'noise.sigma_r_deg'" in err
    assert "cell 0" not in err and len(err) < 800
    assert not out.exists()


def test_report_counts_the_cells_that_ran_not_the_file(tmp_path):
    from simcalib.studies.sweep.cells import resolve_cells
    from simcalib.studies.sweep.report import write_report
    spec = load_sweep("noise", {"seeds": 2})
    resolved = resolve_cells(spec, expand(spec), output=tmp_path)
    store.write_manifest(tmp_path, spec, [c for c, _ in resolved])
    report = write_report(tmp_path).read_text()
    assert "20 seeds" not in report and "200 cells" not in report
    assert "Cells: 20 = 10 combinations of the swept values x 2 seeds" in report


def test_error_plots_use_a_log_scale(tmp_path, monkeypatch):
    from matplotlib.figure import Figure
    from simcalib.studies.sweep.report import _plot
    figures = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: figures.append(self))
    st = lambda rot, tr: {"rot_med": rot, "rot_q1": rot, "rot_q3": rot, "tr_med": tr,
                          "tr_q1": tr, "tr_q3": tr, "failed": 0.0, "degenerate": 0.0}
    # good solvers at 1-2 cm, one bad one at 5 m: each line alone spans < 2x
    per_axis = {"noise.sigma_r_deg": {
        v: {"dqopt": st(0.1 * v, 0.01 * v), "dq2steps": st(0.12 * v, 0.012 * v),
            "daniilidis": st(3 * v, 5.0 * v)} for v in (1.0, 1.5, 2.0)}}
    _plot(per_axis, "noise.sigma_r_deg", tmp_path)
    (fig,) = figures
    assert [ax.get_yscale() for ax in fig.axes[:2]] == ["log", "log"]
