"""Advice for recorded pose files (simcalib.studies.advise.recorded, ``advise a=... b=...``): the
cart's plane, the candidates' kinematics, the CLI's outputs, and — against ground truth —
that recording the advised stops improves the calibration of synthetic files."""

import json

import numpy as np
import pytest

from simcalib.studies.advise import recorded as rc
from simcalib.geometry import (invert_transform, matrix_from_rotvec, rotation_error_rad,
                               rotvec_from_matrix)
from simcalib.report.results import write_tum

X_TRUE = np.eye(4)
X_TRUE[:3, :3] = matrix_from_rotvec(np.radians([8.0, -4.0, 12.0]))
X_TRUE[:3, 3] = [0.05, -0.09, 0.06]


def _pose(rotvec, t):
    T = np.eye(4)
    T[:3, :3] = matrix_from_rotvec(np.asarray(rotvec, dtype=float))
    T[:3, 3] = t
    return T


def _noisy(T, rng, s_r=2e-4, s_t=2e-4):
    E = np.stack([_pose(rng.normal(0, s_r, 3), rng.normal(0, s_t, 3)) for _ in range(len(T))])
    return T @ E


def _trajectory(kind, n=200):
    """Sensor a's poses along a degenerate path: ``planar`` (yaw and planar moves: a cart)
    or ``vertical_axis`` (3D moves rotating about one vertical axis: a SCARA arm)."""
    s = np.linspace(0, 2 * np.pi, n)
    yaw = 0.8 * np.sin(s)
    z = np.zeros(n) if kind == "planar" else 0.2 * np.sin(2 * s)
    return np.stack([_pose([0, 0, yw], [np.cos(si), 0.7 * np.sin(si), zi])
                     for yw, si, zi in zip(yaw, s, z)])


def _write_files(tmp_path, T_a, seed=0):
    """TUM files of sensor a (its world) and sensor b (another world: ``Y T_a X``)."""
    rng = np.random.default_rng(seed)
    Y = _pose([0.1, 0.2, -0.3], [1.0, 2.0, 0.5])
    T_b = Y @ T_a @ X_TRUE
    t = np.arange(len(T_a)) * 0.1
    return (write_tum(tmp_path / "a.tum", t, _noisy(T_a, rng)),
            write_tum(tmp_path / "b.tum", t, _noisy(T_b, rng)))


def test_plane_normal_of_a_cart_and_refusal_of_3d_motion():
    T = _trajectory("planar")
    C = invert_transform(T[:-5]) @ T[5:]
    n = rc.plane_normal(C)
    assert np.allclose(n, [0, 0, 1], atol=1e-9)
    R = matrix_from_rotvec(np.array([0.3, -0.2, 0.1]))        # the same, in a tilted frame
    Ct = C.copy()
    Ct[:, :3, :3] = R @ C[:, :3, :3] @ R.T
    Ct[:, :3, 3] = C[:, :3, 3] @ R.T
    assert np.allclose(rc.plane_normal(Ct), R[:, 2], atol=1e-9)
    rng = np.random.default_rng(1)
    C3 = np.stack([_pose(rng.normal(0, 0.5, 3), rng.normal(0, 0.3, 3)) for _ in range(20)])
    with pytest.raises(ValueError, match="planar motion.*spread.*platform=free"):
        rc.plane_normal(C3)
    C_lift = C.copy()                                # a SCARA: vertical moves as well
    C_lift[:, 2, 3] = np.linspace(-0.2, 0.2, len(C))
    with pytest.raises(ValueError, match="leave that plane by .* platform=free"):
        rc.plane_normal(C_lift)
    with pytest.raises(ValueError, match="rotate by 0 deg"):
        rc.plane_normal(np.repeat(np.eye(4)[None], 3, axis=0))


@pytest.mark.parametrize("platform", rc.PLATFORMS)
def test_candidates_respect_the_platform(platform):
    T = _trajectory("planar")
    C = invert_transform(T[:-5]) @ T[5:]
    M = rc.motion_candidates(C, 500, np.random.default_rng(0), platform)
    w = rotvec_from_matrix(M[:, :3, :3])
    ang = np.degrees(np.linalg.norm(w, axis=1))
    if platform == "free":
        assert 5.0 - 1e-9 <= ang.min() and ang.max() <= 90.0 + 1e-9
        assert np.linalg.norm(M[:, :3, 3], axis=1).max() <= 0.30 + 1e-12
        assert np.abs(w[:, 2]).mean() < 2 * np.abs(w[:, 0]).mean()    # every axis
    else:
        assert np.allclose(w[:, :2], 0, atol=1e-12) and ang.max() <= 90.0 + 1e-9
        assert np.allclose(M[:, 2, 3], 0, atol=1e-12)              # in the plane
        assert np.linalg.norm(M[:, :3, 3], axis=1).max() <= 1.0 + 1e-12
    with pytest.raises(ValueError, match="platform must be one of"):
        rc.motion_candidates(C, 5, np.random.default_rng(0), "arm")


def _solve_errors(C, H):
    import simcalib
    X = np.asarray(simcalib.solve(C, H, method="dqopt").X)
    return (np.degrees(rotation_error_rad(X, X_TRUE)),
            100 * np.linalg.norm(X[:3, 3] - X_TRUE[:3, 3]))


def test_free_advice_on_scara_files_determines_x_against_ground_truth(tmp_path, capsys):
    """SCARA-like files leave X's translation along the vertical undetermined; recording
    the 3 advised stops (synthetic, with the files' noise) determines it within 1 mm, better than 3
    random stops of the same ranges (ground truth decides)."""
    from simcalib.cli import main
    a, b = _write_files(tmp_path, _trajectory("vertical_axis"))
    out = tmp_path / "adv"
    code = main(["advise", f"a={a}", f"b={b}", "platform=free", f"output={out}", "k=3",
                 "candidates=300", "time_offset=0"])
    assert code == 0
    res = json.loads((out / "advice.json").read_text())
    assert (out / "advice.rrd").is_file()
    assert res["platform"] == "free" and len(res["motions"]) == 3
    vz = res["predicted_std_before"]["vz_m"]
    assert vz is None or vz > 0.05                  # undetermined or worse than 5 cm
    maxes = [res["max_std_tolerance_units_before"]] + [
        m["max_std_tolerance_units_after"] for m in res["motions"]]
    assert all(x2 <= x1 * (1 + 1e-9) for x1, x2 in zip(maxes, maxes[1:]))
    assert res["motions"][-1]["predicted_std_after"]["vz_m"] < 0.01
    assert "not checked" in capsys.readouterr().out
    # record the advised stops (stop and go from the reference) with the files' noise
    rng = np.random.default_rng(5)
    T_ref = np.asarray(res["reference"]["T_frame_a"])
    stops = np.stack([T_ref] + [np.asarray(m["T_frame_a_target"]) for m in res["motions"]])
    T_a = _trajectory("vertical_axis")
    C_rec = invert_transform(T_a[:-10]) @ T_a[10:]
    H_rec = invert_transform(X_TRUE) @ C_rec @ X_TRUE

    def with_stops(S):
        Sa, Sb = _noisy(S, rng), _noisy(S @ X_TRUE, rng)
        Cs = invert_transform(Sa[:-1]) @ Sa[1:]
        Hs = invert_transform(Sb[:-1]) @ Sb[1:]
        return _solve_errors(np.concatenate([_noisy(C_rec, rng), Cs]),
                             np.concatenate([_noisy(H_rec, rng), Hs]))

    adv_err = with_stops(stops)
    M = rc.motion_candidates(C_rec, 3, np.random.default_rng(9), "free")
    rand_err = with_stops(np.concatenate([T_ref[None], T_ref @ M]))
    assert adv_err[0] < 0.1 and adv_err[1] < 0.2                 # deg, cm: determined
    assert adv_err[1] < rand_err[1]


def test_cart_files_state_what_they_cannot_help_and_bad_options(tmp_path, capsys):
    from simcalib.cli import main
    a, b = _write_files(tmp_path, _trajectory("planar"))
    out = tmp_path / "cart"
    assert main(["advise", f"a={a}", f"b={b}", "platform=cart", f"output={out}", "k=2",
                 "candidates=100", "time_offset=0", "recording=false"]) == 0
    res = json.loads((out / "advice.json").read_text())
    assert not (out / "advice.rrd").exists()
    assert any(c["kind"] == "translation" and abs(c["translation_dir_a"][2]) > 0.99
               for c in res["cannot_help"])
    assert "prior_weight_translation" in res["cannot_help"][0]["fix"]
    # the vertical is undetermined (null), the five other axes are predicted finite
    for std in [res["predicted_std_before"]] + [m["predicted_std_after"] for m in res["motions"]]:
        assert std["vz_m"] is None and all(v is not None for k, v in std.items() if k != "vz_m")
    for m in res["motions"]:                 # about the plane's normal (estimated), in it
        rv = np.asarray(m["sensor_motions"]["a"]["rotvec_deg"])
        t = np.asarray(m["sensor_motions"]["a"]["translation_m"])
        assert np.linalg.norm(rv[:2]) < 1e-3 * np.linalg.norm(rv)
        assert abs(t[2]) < 1e-3 * np.linalg.norm(t)
    assert "cannot help" in capsys.readouterr().out
    for args, msg in (([], "needs platform="), (["platform=arm"], "received 'arm'"),
                      (["platform=free", "verify=true"], "verify needs a simulated scenario")):
        assert main(["advise", f"a={a}", f"b={b}", f"output={out}", *args]) == 2
        assert msg in capsys.readouterr().err


def test_bad_pose_files_are_bad_input_as_in_calibrate(tmp_path, capsys):
    """Pose files in different length units: exit 3 (bad input), not 2 (usage)."""
    from simcalib.cli import main
    a, b = _write_files(tmp_path, _trajectory("vertical_axis"))
    rows = np.loadtxt(a)
    mm = tmp_path / "a_mm.tum"
    np.savetxt(mm, np.column_stack([rows[:, 0], 1e3 * rows[:, 1:4], rows[:, 4:]]))
    assert main(["advise", f"a={mm}", f"b={b}", "platform=free",
                 f"output={tmp_path / 'out'}"]) == 3
    assert "different units" in capsys.readouterr().err
