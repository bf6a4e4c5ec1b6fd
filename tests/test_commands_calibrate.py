"""``simcalib calibrate``: the simulation round trip through files (issue 11 §5), exit codes,
options, outputs, and the ETH data sets (skipped when absent)."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from simcalib.cli import main
from simcalib.errors import EXIT_CONFIG, EXIT_DEGENERATE, EXIT_INPUT, EXIT_OK
from simcalib.geometry import (invert_transform, matrix_from_rotvec, quat_from_matrix,
                               rotation_error_rad, translation_error_m)
from simcalib.report.results import write_tum
from simcalib.world.stream_sim import rig_streams

ETH = Path(os.environ.get("SIMCALIB_ETH_DIR",
                          Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "eth"))


def _calibrate(capsys, *args):
    code = main(["calibrate", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.slow
def test_round_trip_simulated_run(tmp_path, capsys):
    """A simulated run (UR5e arm, 3d path, noisy poses 0.1 deg / 1 mm at 30 Hz) exported as
    files (``simcalib.studies.experiments.streams.export_run_streams``): a as simcalib TUM; b at
    15 Hz, stamped 37 ms late, 3 % of its poses gross outliers, written INVERTED with
    SCALAR-FIRST quaternions in the header-less ETH layout. The command must find the
    reading (clearly), the offset (within 3 ms), reject outlier motions, and give X within
    0.1 deg / 3 mm of the truth and within 1.5x (+0.005 deg / 0.2 mm) of dqopt on the same
    poses synchronous and outlier-free; the plain solve (offset 0, no rejection) is >= 10x
    worse in translation."""
    from simcalib.studies.experiments.streams import roundtrip
    r = roundtrip(tmp_path)
    text = capsys.readouterr().out
    rep = r["report"]
    assert r["exit"] == EXIT_OK and rep["status"] == "determined", text
    conv = rep["conventions"]
    assert conv["invert_b"] and conv["swap_scalar_b"] and not conv["invert_a"], conv["message"]
    assert conv["clear"], conv["message"]
    assert abs(r["offset_error_ms"]) < 3.0, rep["time_offset"]["message"]
    assert r["rotation_error_deg"] < 0.1 and r["translation_error_mm"] < 3.0, r
    assert r["rotation_error_deg"] <= 1.5 * r["run_rotation_error_deg"] + 0.005, r
    assert r["translation_error_mm"] <= 1.5 * r["run_translation_error_mm"] + 0.2, r
    assert r["plain_translation_error_mm"] > 10 * r["translation_error_mm"], r
    inl = rep["inliers"]
    assert inl["n_inliers"] < inl["n_motions"]
    out = tmp_path / "calibration"
    m = np.load(out / "motions.npz")
    assert m["C"].shape == (inl["n_motions"], 4, 4) and m["inlier"].sum() == inl["n_inliers"]
    for word in ("X = T_a_b", "quaternion (x,y,z,w)", "uncertainty", "verdict: DETERMINED",
                 "time offset t_b - t_a: 3", "inliers:", "residuals", "conventions:",
                 "inverted", "swapped", "status: determined (exit 0)"):
        assert word in text, word
    from rerun.chunk import RrdReader
    summary = str(RrdReader(str(out / "recording.rrd")).store().summary())
    assert "/time_offset/window" in summary and "/time_offset/chosen" in summary
    assert "/offset_cost" in summary


def _rig_files(tmp_path, path="3d", offset_s=0.0, seed=1):
    rs = rig_streams(offset_s=offset_s, duration_s=15.0, path=path,
                     rng=np.random.default_rng(seed))
    pa = write_tum(tmp_path / f"{path}_a.tum", rs.t_a, rs.T_a)
    pb = write_tum(tmp_path / f"{path}_b.tum", rs.t_b, rs.T_b)
    return rs, pa, pb


@pytest.mark.slow
def test_outputs_schema_recording_and_given_offset(tmp_path, capsys):
    rs, pa, pb = _rig_files(tmp_path, offset_s=0.02)
    out = tmp_path / "o"
    code, text, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={out}",
                                 "time_offset=0.02", "robust=none", "step_s=0.5")
    assert code == EXIT_OK, err
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["schema"] == "simcalib.calibration/1" and rep["exit_code"] == 0
    for key in ("X", "uncertainty", "verdict", "time_offset", "inliers", "residuals",
                "conventions", "streams", "plain", "solution", "options", "warnings"):
        assert key in rep, key
    assert rep["time_offset"]["offset_s"] == 0.02 and not rep["time_offset"]["estimated"]
    assert rep["inliers"]["robust"] == "none"
    assert rep["options"]["step_s"] == 0.5
    # what sigma cannot hold is said in the file and on the console
    assert "common to every pose" in rep["uncertainty"]["not_included"]
    assert f"not in sigma: {rep['uncertainty']['not_included']}" in text
    q = np.array(rep["X"]["quaternion_xyzw"])
    assert abs(np.linalg.norm(q) - 1) < 1e-9
    assert np.degrees(rotation_error_rad(np.array(rep["X"]["T_a_b"]), rs.X)) < 0.05
    from rerun.chunk import RrdReader
    summary = str(RrdReader(str(out / "recording.rrd")).store().summary())
    for ent in ("/world/b_from_a/trajectory", "/world/b_measured/trajectory",
                "/world/rig/a", "/residuals/rotation_deg/inliers", "/summary"):
        assert ent in summary, ent
    assert "/time_offset/window" not in summary         # no curve: offset given


@pytest.mark.slow
def test_degenerate_motion_exits_6_and_still_writes(tmp_path, capsys):
    """Planar path: all rotations about the vertical, X's vertical translation is not
    determined."""
    _, pa, pb = _rig_files(tmp_path, path="planar")
    out = tmp_path / "o"
    code, text, _ = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={out}",
                               "time_offset=0", "recording=false")
    assert code == EXIT_DEGENERATE
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["status"] == "degenerate" and rep["verdict"]["degenerate"]
    assert rep["verdict"]["directions"] and "translation" in rep["verdict"]["directions"][0]
    assert "exit 6" in text and not (out / "recording.rrd").exists()


@pytest.mark.slow
def test_prior_inline_and_from_a_calibration_json(tmp_path, capsys):
    rs, pa, pb = _rig_files(tmp_path, path="planar")
    t = rs.X[:3, 3]
    q = quat_from_matrix(rs.X[:3, :3])
    inline = "[" + ",".join(f"{v:.9f}" for v in [*t, *q]) + "]"
    out = tmp_path / "p"
    code, _, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={out}", "time_offset=0",
                              f"prior={inline}", "recording=false")
    assert code in (EXIT_OK, EXIT_DEGENERATE), err
    rep = json.loads((out / "calibration.json").read_text())
    X = np.array(rep["X"]["T_a_b"])
    assert translation_error_m(X, rs.X) < 2e-3      # the prior fixes the vertical
    assert rep["solution"]["prior"] is not None
    code2, _, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={tmp_path / 'p2'}",
                               "time_offset=0", f"prior={out / 'calibration.json'}",
                               "recording=false")
    rep2 = json.loads((tmp_path / "p2" / "calibration.json").read_text())
    assert code2 == code and np.allclose(rep2["solution"]["prior"]["X"], X)


def test_errors_have_exit_codes(tmp_path, capsys):
    _, pa, pb = _rig_files(tmp_path)
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3 4 5 6 7 8\n")
    rows = np.loadtxt(pa)
    mm, ns, ns_b = tmp_path / "a_mm.txt", tmp_path / "a_ns.txt", tmp_path / "b_ns.txt"
    np.savetxt(mm, np.column_stack([rows[:, 0], 1e3 * rows[:, 1:4], rows[:, 4:]]))
    # both files relative ns, 20 poses each: too few to show a motion, the same span
    for path, src in ((ns, rows), (ns_b, np.loadtxt(pb))):
        few = src[::10][:20]
        np.savetxt(path, np.column_stack([1e9 * few[:, 0], few[:, 1:]]), fmt="%.17g")
    cases = [
        ([f"a={mm}", f"b={pb}", f"output={tmp_path}"], EXIT_INPUT, "different units"),
        ([f"a={ns}", f"b={ns_b}", f"output={tmp_path}"], EXIT_INPUT, "the unit cannot be told"),
        ([f"a={ns}", f"b={ns_b}", f"output={tmp_path}"], EXIT_INPUT, "stamps_unit_a=ms"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "stamps_unit_a=min"], EXIT_CONFIG,
         "stamps_unit_a"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "robus=none"], EXIT_CONFIG,
         "did you mean 'robust'"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "method=dqop"], EXIT_CONFIG,
         "did you mean 'dqopt'"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "format=tun"], EXIT_CONFIG,
         "did you mean 'tum'"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "time_offset=soon"], EXIT_CONFIG,
         "time_offset"),
        ([f"b={pb}", f"output={tmp_path}"], EXIT_CONFIG, "'a'"),
        ([f"a={pa}", f"b={tmp_path / 'missing.tum'}", f"output={tmp_path}"], EXIT_INPUT,
         "does not exist"),
        ([f"a={pa}", f"b={bad}", f"output={tmp_path}"], EXIT_INPUT, "unit quaternions"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "time_offset=100"], EXIT_INPUT,
         "too few overlapping poses"),
        ([f"a={pa}", f"b={pb}", f"output={tmp_path}", "prior=[1,2]"], EXIT_INPUT,
         "7 numbers"),
    ]
    for args, want, words in cases:
        code, _, err = _calibrate(capsys, *args)
        assert code == want and words in err, (args, code, err)


def test_stamps_relative_in_ms_are_told_rescaled_and_named_as_a_repair(tmp_path, capsys):
    # file a stamped from its first pose in ms, b in seconds: read as they are, a would
    # span 1000 times b (before: "too few overlapping poses", exit 3)
    rs, pa, pb = _rig_files(tmp_path, offset_s=0.02)
    rows = np.loadtxt(pa)
    ms = tmp_path / "a_ms.txt"
    np.savetxt(ms, np.column_stack([1e3 * (rows[:, 0] - rows[0, 0]), rows[:, 1:]]),
               fmt="%.17g")
    out = tmp_path / "ms"
    code, text, err = _calibrate(capsys, f"a={ms}", f"b={pb}", f"output={out}",
                                 "recording=false")
    assert code in (EXIT_OK, EXIT_DEGENERATE), err
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["streams"]["a"]["repairs"] == {"stamps_ms_to_s": rows.shape[0]}
    assert rep["streams"]["b"]["repairs"] == {}
    assert "stamps_ms_to_s" in text and "relative to the recording" in text
    X = np.array(rep["X"]["T_a_b"])
    assert np.degrees(rotation_error_rad(X, rs.X)) < 0.5
    assert abs(rep["time_offset"]["offset_s"] - (0.02 + rows[0, 0])) < 3e-3
    # the unit given: read as seconds on request, the spans then 1000x apart again
    code, _, err = _calibrate(capsys, f"a={ms}", f"b={pb}", f"output={tmp_path / 's'}",
                              "recording=false", "stamps_unit_a=s")
    assert code == EXIT_INPUT, err
    code, _, err = _calibrate(capsys, f"a={ms}", f"b={pb}", f"output={tmp_path / 'g'}",
                              "recording=false", "stamps_unit_a=ms")
    assert code in (EXIT_OK, EXIT_DEGENERATE), err
    rep = json.loads((tmp_path / "g" / "calibration.json").read_text())
    assert rep["streams"]["a"]["repairs"] == {} and "(given)" in rep["streams"]["a"]["detection"]


@pytest.mark.slow
def test_irls_calibrates(tmp_path, capsys):
    _, pa, pb = _rig_files(tmp_path)
    code, _, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={tmp_path / 'i'}",
                              "robust=irls", "time_offset=0", "recording=false")
    assert code == EXIT_OK, err


def test_assess_uses_the_uncertainty_and_its_consistency_check():
    """The one quality function takes the verdict and the sigmas from the reported
    covariance (the poses' own errors, checked by the recording's halves); degenerate
    motion exits with EXIT_DEGENERATE (6) and names the direction."""
    from simcalib.estimation.path import calibrate_streams
    from simcalib.pipeline.calibrate import assess
    from simcalib.importers import stream_from_arrays
    rs = rig_streams(duration_s=15.0, rng=np.random.default_rng(0))
    r = calibrate_streams(stream_from_arrays(rs.t_a, rs.T_a), stream_from_arrays(rs.t_b, rs.T_b),
                          time_offset=0.0)
    a = assess(r)
    assert a.verdict == "determined" and not a.degenerate and a.exit_code == 0, a.summary
    assert a.source.startswith("the poses' own errors") and "two halves" in a.source
    reported = np.sqrt(np.diag(r.consistency.covariance))
    assert np.allclose(np.radians(a.std_rot_deg), reported[:3], rtol=1e-9)
    assert np.allclose(a.std_trans_m, reported[3:], rtol=1e-9)
    rs = rig_streams(duration_s=15.0, path="planar", rng=np.random.default_rng(1))
    r = calibrate_streams(stream_from_arrays(rs.t_a, rs.T_a), stream_from_arrays(rs.t_b, rs.T_b),
                          time_offset=0.0)
    a = assess(r)
    assert a.degenerate and a.verdict != "determined" and a.exit_code == EXIT_DEGENERATE == 6
    assert any("translation" in d for d in a.undetermined), a.undetermined


@pytest.mark.slow
@pytest.mark.skipif(not ETH.is_dir(), reason=f"ETH data sets not present at {ETH} "
                    "(set SIMCALIB_ETH_DIR)")
def test_eth_prime_sense_with_the_command(tmp_path, capsys):
    from simcalib.studies.experiments.streams import eth_files
    fa, fb = eth_files(ETH, tmp_path / "eth")["prime_sense_1"]
    out = tmp_path / "ps"
    code, text, err = _calibrate(capsys, f"a={fa}", f"b={fb}", f"output={out}",
                                 "recording=false")
    rep = json.loads((out / "calibration.json").read_text())
    assert code == rep["exit_code"] and code in (EXIT_OK, EXIT_DEGENERATE), err
    assert abs(rep["time_offset"]["offset_s"] + 0.024) < 0.01     # ~ -24 ms
    assert rep["conventions"]["clear"] and not rep["conventions"]["invert_b"]
    assert rep["inliers"]["n_inliers"] >= 0.8 * rep["inliers"]["n_motions"]
    assert rep["residuals"]["inliers"]["rot_rms_deg"] < rep["plain"]["residuals"]["rot_rms_deg"]


@pytest.mark.slow
def test_two_stream_sample_file_alone(tmp_path, capsys):
    """easy_handeye samples (robot + tracking = target in camera): ``a=`` alone; the
    tracking stream is found inverted; sample index as time, no offset estimated."""
    import yaml
    rs = rig_streams(duration_s=15.0, rng=np.random.default_rng(3))
    from simcalib.estimation.alignment import synchronise
    sp = synchronise(rs.a, rs.b, 0.0)
    k = np.linspace(0, sp.n - 1, 30).round().astype(int)

    def tf(T):
        q = quat_from_matrix(T[:3, :3])
        return {"translation": dict(zip("xyz", map(float, T[:3, 3]))),
                "rotation": dict(zip("xyzw", map(float, q)))}
    doc = [{"robot": tf(A), "tracking": tf(B)}
           for A, B in zip(sp.T_a[k], invert_transform(sp.T_b[k]))]
    p = tmp_path / "samples.yaml"
    p.write_text(yaml.safe_dump(doc))
    out = tmp_path / "o"
    code, text, err = _calibrate(capsys, f"a={p}", f"output={out}", "recording=false")
    assert code == EXIT_OK, err + text
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["conventions"]["invert_b"] and rep["streams"]["a"]["sample_index_as_time"]
    assert rep["time_offset"]["offset_s"] == 0.0
    assert np.degrees(rotation_error_rad(np.array(rep["X"]["T_a_b"]), rs.X)) < 0.2


@pytest.mark.slow
def test_first_use_calibrates_with_interpreted_kernels(tmp_path, capsys):
    """The first calibrate on an installation (cold numba cache) solves with the kernels'
    Python functions (simcalib.solvers.kernels.mode): same X to rounding, and the report says so."""
    import subprocess
    import sys
    rs, pa, pb = _rig_files(tmp_path)
    args = [f"a={pa}", f"b={pb}", "time_offset=0", "robust=none", "step_s=0.5",
            "recording=false"]
    code, _, err = _calibrate(capsys, *args, f"output={tmp_path / 'c'}")
    assert code == EXIT_OK, err
    env = dict(os.environ, SIMCALIB_KERNELS="interpreted")
    proc = subprocess.run([sys.executable, "-m", "simcalib", "calibrate", *args,
                           f"output={tmp_path / 'i'}"], env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == EXIT_OK, proc.stderr
    assert "solver kernels: interpreted" in proc.stdout
    c = json.loads((tmp_path / "c" / "calibration.json").read_text())
    i = json.loads((tmp_path / "i" / "calibration.json").read_text())
    assert c["solver_kernels"] == "compiled" and i["solver_kernels"] == "interpreted"
    np.testing.assert_allclose(np.array(i["X"]["T_a_b"]), np.array(c["X"]["T_a_b"]),
                               atol=1e-10)


def test_verdict_tolerances_are_keys_of_calibrate(tmp_path, capsys):
    """verdict.tolerance_deg / tolerance_m set what 'poorly determined' means (as in a
    scenario): the same planar files are degenerate at 1 cm and say so in words, and a
    bad tolerance is a usage error naming the key."""
    from simcalib.pipeline.calibrate import parse_options
    from simcalib.errors import ConfigError
    opts = parse_options(["a=x", "b=y", "output=o", "verdict.tolerance_deg=2.5",
                          "verdict.tolerance_m=0.05"])
    assert opts.verdict.tolerance_deg == 2.5 and opts.verdict.tolerance_m == 0.05
    with pytest.raises(ConfigError, match="tolerance_m"):
        parse_options(["a=x", "b=y", "output=o", "verdict.tolerance_m=-1"])
    _, pa, pb = _rig_files(tmp_path)
    tight, loose = tmp_path / "tight", tmp_path / "loose"
    base = [f"a={pa}", f"b={pb}", "time_offset=0", "recording=false"]
    _calibrate(capsys, *base, f"output={tight}", "verdict.tolerance_m=1e-5")
    _calibrate(capsys, *base, f"output={loose}", "verdict.tolerance_m=1.0",
               "verdict.tolerance_deg=10")
    rt = json.loads((tight / "calibration.json").read_text())
    rl = json.loads((loose / "calibration.json").read_text())
    assert rt["verdict"]["verdict"] == "poorly determined" and rt["exit_code"] == 6
    assert rl["verdict"]["verdict"] == "determined" and rl["exit_code"] == 0
    assert rl["options"]["verdict"] == {"tolerance_deg": 10.0, "tolerance_m": 1.0}


def test_the_same_file_twice_is_bad_input(tmp_path, capsys):
    _, pa, _ = _rig_files(tmp_path)
    code, text, err = _calibrate(capsys, f"a={pa}", f"b={pa}", f"output={tmp_path / 'o'}",
                                 "recording=false")
    assert code == 3 and "hold the same" in err and "given twice" in err, (code, text, err)


def test_a_world_frame_that_jumps_is_warned_about(tmp_path, capsys):
    """A SLAM map reset half-way: both stretches are used, each as its own world, and the
    run says so."""
    rs = rig_streams(duration_s=15.0, rng=np.random.default_rng(1))
    G = np.eye(4)
    G[:3, :3], G[:3, 3] = matrix_from_rotvec([0.6, -0.5, 0.6]), [0.5, -0.4, 0.5]
    T_b = rs.T_b.copy()
    T_b[120:] = G @ T_b[120:]
    pa = write_tum(tmp_path / "a.tum", rs.t_a, rs.T_a)
    pb = write_tum(tmp_path / "b.tum", rs.t_b, T_b)
    code, text, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={tmp_path / 'o'}",
                                 "recording=false")
    assert code == 0 and "WARNING: stream" in text and "world frame jumps 1 time(s)" in text, \
        text
    assert "each of its 2 stretches is used as its own world" in text
    assert "2 of 2 stretches of the two streams' worlds give the fit's motions" in text
    assert "world_stretches: 2" in text and "world_jumps: 1" in text


def test_two_recordings_in_one_file_are_warned_about(tmp_path, capsys):
    rs = rig_streams(duration_s=15.0, rng=np.random.default_rng(1))
    t_b = rs.t_b.copy()
    t_b[100:] -= 4.0 + 0.013                      # the logger restarted 4 s back
    pa = write_tum(tmp_path / "a.tum", rs.t_a, rs.T_a)
    pb = tmp_path / "b.tum"
    rows = np.column_stack([t_b, rs.T_b[:, :3, 3], quat_from_matrix(rs.T_b[:, :3, :3])])
    np.savetxt(pb, rows, fmt="%.9f")
    code, text, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={tmp_path / 'o'}",
                                 "recording=false")
    assert code == 0 and "stamps go back 1 time(s)" in text, text + err
    assert "rows_of_other_recordings_dropped: 100" in text



def test_two_files_each_of_two_recordings_pair_the_same_recording(tmp_path, capsys):
    """Both loggers restarted (two sessions appended to each file, stamps from 0 again):
    each file's longest recording may be another session; the pair keeps the same one."""
    rs = rig_streams(duration_s=20.0, rng=np.random.default_rng(2))
    rows = {}
    for k, (t, T, cut) in {"a": (rs.t_a, rs.T_a, 9.8), "b": (rs.t_b, rs.T_b, 10.3)}.items():
        t = t - t[0]
        later = t >= cut                      # session 2 re-stamped from 0 (+ 13 ms)
        t = np.where(later, t - cut + 0.013, t)
        rows[k] = tmp_path / f"{k}.tum"
        np.savetxt(rows[k], np.column_stack([t, T[:, :3, 3], quat_from_matrix(T[:, :3, :3])]),
                   fmt="%.9f")
    code, text, err = _calibrate(capsys, f"a={rows['a']}", f"b={rows['b']}",
                                 f"output={tmp_path / 'o'}", "recording=false")
    cal = json.loads((tmp_path / "o" / "calibration.json").read_text())
    X = np.asarray(cal["X"]["T_a_b"])
    assert code == 0 and np.degrees(rotation_error_rad(X, rs.X)) < 0.1, (code, err)
    assert "stamps go back 1 time(s)" in text

@pytest.mark.slow
def test_camera_seen_only_while_still_uses_offset_zero_and_says_why(tmp_path, capsys):
    """stop_and_go: b sees the target only while the arm stands still, so no offset shows;
    the command uses 0, says why and what to do, and pairs the stations (bursts)."""
    from simcalib.studies.experiments.recording_kinds import generate, write_tum
    rec = generate("stop_and_go", 1)
    paths = write_tum(rec, tmp_path)
    code, text, err = _calibrate(capsys, f"a={paths['a']}", f"b={paths['b']}",
                                 f"output={tmp_path / 'out'}", "recording=false")
    assert code == 0, err
    assert "motions: bursts" in text and "not told by the data: 0 used" in text
    assert "cannot tell an offset" in text
    assert "the data do not tell the offset, so 0 is used" in text + err
    cal = json.loads((tmp_path / "out" / "calibration.json").read_text())
    assert cal["time_offset"]["decision"] == "zero" and cal["time_offset"]["offset_s"] == 0.0
    X = np.asarray(cal["X"]["T_a_b"])
    assert np.degrees(rotation_error_rad(X, rec.X_true)) < 0.05


def test_a_reading_the_data_cannot_tell_and_that_moves_x_is_undetermined(tmp_path, capsys):
    """Three stations, the camera file holding T_cam_target: both readings fit (ratio ~1),
    so the files are read as written, and X under the runner-up reading is far beyond the
    sigma: a warning gives that X and the command exits 6 instead of trusting the sigma."""
    from simcalib.geometry import rotvec_from_matrix
    from simcalib.studies.experiments.recording_kinds import generate
    rec = generate("stations_short", 3)
    a, b = rec.stream_a, rec.stream_b
    pa = write_tum(tmp_path / "a.tum", a.timestamps_s, a.T_world_sensor)
    pb = write_tum(tmp_path / "b.tum", b.timestamps_s, invert_transform(b.T_world_sensor))
    code, text, err = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={tmp_path / 'o'}",
                                 "recording=false")
    assert code == EXIT_DEGENERATE, text + err
    rep = json.loads((tmp_path / "o" / "calibration.json").read_text())
    assert not rep["conventions"]["clear"]
    warning = next(w for w in rep["warnings"] if w.startswith("the reading is not told"))
    assert "beyond 3 sigma" in warning and "did not clearly win" not in " ".join(rep["warnings"])
    # the runner-up's X it names is the true one (b inverted), to the noise of 3 stations
    rv = np.degrees(rotvec_from_matrix(rec.X_true[:3, :3]))
    named = [float(x) for x in warning.split("rotvec [")[1].split("]")[0].split(", ")]
    assert np.abs(np.asarray(named) - rv).max() < 3.0, (named, rv)
    # the reading forced (both streams: with b alone forced, a's is chosen relative to it
    # and is as ambiguous), nothing is left to tell
    code2, text2, _ = _calibrate(capsys, f"a={pa}", f"b={pb}", f"output={tmp_path / 'f'}",
                                 "recording=false", "invert_a=false", "invert_b=true")
    assert "the reading is not told" not in text2 and "did not clearly win" not in text2
