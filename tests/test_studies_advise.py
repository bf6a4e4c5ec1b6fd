"""Motion advice (simcalib.studies.advise): information model, greedy choice, feasibility of the
proposed stops, the cart's "cannot help" statement and a small verification run."""

import dataclasses
import json
import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from simcalib.studies.advise import information as info  # noqa: E402
from simcalib.studies.advise import planner as pl  # noqa: E402
from simcalib.geometry import matrix_from_rotvec  # noqa: E402

BASE = ["recording.enabled=false", "progress=false", "world.fps=5", "workers=1"]
SMALL = BASE + ["world.duration_s=6"]


def _motions(rng, n, axes=None, max_angle=0.6, trans=0.2):
    ax = rng.standard_normal((n, 3)) if axes is None else np.asarray(axes, float)
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    C = np.tile(np.eye(4), (n, 1, 1))
    C[:, :3, :3] = matrix_from_rotvec(ax * rng.uniform(0.1, max_angle, (n, 1)))
    C[:, :3, 3] = rng.normal(0, trans, (n, 3))
    return C


def _X():
    X = np.eye(4)
    X[:3, :3] = matrix_from_rotvec(np.array([0.1, -0.2, 0.3]))
    X[:3, 3] = [0.05, -0.09, 0.06]
    return X


def test_information_adds_up_to_the_uncertainty_models():
    from simcalib.solvers.diagnostics.uncertainty import NoiseModel, covariance
    rng = np.random.default_rng(0)
    X = _X()
    C = _motions(rng, 30)
    H = np.linalg.inv(X) @ C @ X
    F = info.motion_information(C, H, X, 0.01, 0.002).sum(axis=0)
    u = covariance(C, H, X, 1.0, noise=NoiseModel(0.01, 0.002))
    np.testing.assert_allclose(F, u.information, rtol=1e-6, atol=1e-9 * np.abs(F).max())


def test_greedy_picks_the_motion_that_fixes_the_degeneracy_and_decreases_monotonically():
    rng = np.random.default_rng(1)
    X = _X()
    Cb = _motions(rng, 40, axes=np.tile([0.0, 0.0, 1.0], (40, 1)))     # one rotation axis
    Fb = info.motion_information(Cb, np.linalg.inv(X) @ Cb @ X, X, 0.005, 0.001).sum(0)
    Cc = np.concatenate([_motions(rng, 20, axes=np.tile([0.0, 0.0, 1.0], (20, 1))),
                         _motions(rng, 20)])
    Fc = info.motion_information(Cc, np.linalg.inv(X) @ Cc @ X, X, 0.005, 0.001)
    g = pl.greedy(Fb, Fc, 4)
    assert g.order[0] >= 20                      # a motion about another axis comes first
    assert np.isinf(g.max_std_tol[0]) or g.max_std_tol[0] > 1e3
    assert np.all(np.diff(g.criterion) <= 1e-12)
    assert np.all(np.diff(g.max_std_tol[1:]) <= 1e-12)
    assert len(set(g.order.tolist())) == 4
    s0 = info.predicted_std(Fb)
    assert np.isinf(s0[5])                       # translation along z undetermined
    feas = np.zeros(40, bool)
    feas[:20] = True                             # only motions about z are feasible
    assert pl.greedy(Fb, Fc, 2, feasible=feas).order.max() < 20
    with pytest.raises(ValueError, match="k must be"):
        pl.greedy(Fb, Fc, 0)


def test_undeterminable_names_the_vertical_translation_and_its_fix():
    rng = np.random.default_rng(2)
    X = _X()
    C = _motions(rng, 30, axes=np.tile([0.0, 0.0, 1.0], (30, 1)))
    C[:, 2, 3] = 0.0                              # planar
    F = info.motion_information(C, np.linalg.inv(X) @ C @ X, X, 0.005, 0.001)
    out = info.undeterminable(F.sum(0), F)
    assert len(out) == 1 and out[0]["kind"] == "translation"
    assert abs(out[0]["translation_dir_a"][2]) > 0.99
    assert "prior" in out[0]["fix"]


def test_one_rotation_axis_leaves_one_direction_undetermined_and_five_determined():
    """Motions that all rotate about one axis (a SCARA's, a cart's vertical) leave X's
    translation along it undetermined, and only that: the other five directions get finite
    1-sigma on the determined subspace — also when the recorded motions carry a little
    spurious information along the undetermined direction, mixed with the others (a
    marker map's tilt), which inverting the whole information turned into 'every axis
    undetermined' — and the choice ranks stops by what they improve there."""
    rng = np.random.default_rng(7)
    X = _X()
    about_z = lambda n: _motions(rng, n, axes=np.tile([0.0, 0.0, 1.0], (n, 1)))  # noqa: E731
    Cb, M = about_z(40), about_z(60)
    Fb = info.motion_information(Cb, np.linalg.inv(X) @ Cb @ X, X, 0.005, 0.001).sum(0)
    v = np.array([0.02, 0.0, 0.0, 0.0, 0.03, 1.0])                # mostly vz, mixed
    dsc = info.tolerance_scale(1.0, 0.01)
    Fb_spurious = Fb + 0.5 * np.outer(v / dsc, v / dsc) / (v @ v)  # 1-sigma ~1.4 cm along v
    Fc = info.motion_information(M, np.linalg.inv(X) @ M @ X, X, 0.005, 0.001)
    for F0 in (Fb, Fb_spurious):
        U = info.undeterminable_directions(F0, Fc)
        assert U.shape == (6, 1) and abs(U[5, 0]) > 0.999        # X's translation along z
        out = info.undeterminable(F0, Fc)
        assert len(out) == 1 and out[0]["kind"] == "translation"
        assert abs(out[0]["translation_dir_a"][2]) > 0.99
        g, added = pl.greedy_chain(F0, M, X, 0.005, 0.001, 4, undetermined=U)
        s = info.predicted_std(F0 + added.sum(0), undetermined=U)
        assert np.isinf(s[5]) and np.isfinite(s[:5]).all() and (s[:5] > 0).all()
        # the choice works on the five: its largest 1-sigma is finite and never rises
        assert np.isfinite(g.max_std_tol).all() and np.all(np.diff(g.max_std_tol) <= 1e-12)
        assert np.all(np.diff(g.criterion) <= 1e-12) and len(set(g.order.tolist())) == 4
        # its criterion is that of the information restricted to the five directions
        Bc = info.complement(U)
        Fr = Bc.T @ ((F0 + added.sum(0)) * np.outer(dsc, dsc)) @ Bc
        lam = np.linalg.eigvalsh(Fr)
        crit = np.max(1 / (lam + pl.EPS)) + np.mean(1 / (lam + pl.EPS))
        assert g.criterion[-1] == pytest.approx(crit, rel=1e-9)
    # the spurious information alone leaves only vz (and the axes it mixes by < 5 %)
    # finite: no axis but vz is reported undetermined
    s = info.predicted_std(Fb_spurious + Fc[:3].sum(0), range_m=0.001)
    assert np.isinf(s[5]) and np.isfinite(s[:5]).all()
    # without undetermined directions the choice is the one it always was
    g0, a0 = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 3)
    g1, a1 = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 3, undetermined=np.zeros((6, 0)))
    np.testing.assert_array_equal(g0.order, g1.order)
    np.testing.assert_array_equal(g0.criterion, g1.criterion)
    with pytest.raises(ValueError, match="undetermined must be"):
        pl.greedy_chain(Fb, M, X, 0.005, 0.001, 2, undetermined=np.ones((6, 1)))


def _six_dof(world):
    """The scara world with its UR5e free to tilt (``world.arm.motions='6dof'``): for the
    feasibility tests of draws about any axis."""
    cfg = world.config
    return dataclasses.replace(world, config=dataclasses.replace(
        cfg, arm=dataclasses.replace(cfg.arm, motions="6dof")))


@pytest.fixture(scope="module")
def scara_advice():
    from simcalib.studies.advise import advise, baseline
    from simcalib.pipeline.scenario import load_config
    cfg = load_config("scara", SMALL + ["camera.width=320", "camera.height=240"])
    base = baseline(cfg)
    return base, advise(base, 3, n_candidates=40)


@pytest.mark.slow
def test_every_proposed_stop_is_feasible(scara_advice):
    import mujoco
    from simcalib.world.layout import visible_markers
    base, adv = scara_advice
    world = base.truth.world
    cand = adv.candidates
    assert adv.chosen.size == 3 and cand.feasible[adv.chosen].all()
    m = world.model
    d = mujoco.MjData(m)
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.scene.mount_site)
    lim = m.jnt_limited.astype(bool)
    for j in adv.chosen:
        q = cand.qpos[j]
        assert (~lim | ((q >= m.jnt_range[:, 0]) & (q <= m.jnt_range[:, 1]))).all()
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        assert np.linalg.norm(d.site_xpos[sid] - cand.T_world_target[j, :3, 3]) <= \
            world.config.ik.fail_pos_m
        R = d.site_xmat[sid].reshape(3, 3)
        ang = np.arccos(np.clip((np.trace(R.T @ cand.T_world_target[j, :3, :3]) - 1) / 2,
                                -1, 1))
        assert ang <= world.config.ik.fail_rot_rad
    from simcalib.studies.advise.feasibility import lens_distortion
    for c in base.aruco_cameras:
        v = visible_markers(world.marker_field, cand.T_world_cam[c][adv.chosen],
                            world.intrinsics[c], distortion=lens_distortion(base.cfg)).sum(axis=1)
        assert (v >= 4).all()
        assert all(n >= 1 for n in adv.render_check[c])     # detected in the render
    # self-collision: none at the chosen stops; a folded elbow is caught
    from simcalib.studies.advise.feasibility import SelfCollision
    collide = SelfCollision(m, cand.ref["qpos"])
    assert all(collide(cand.qpos[j]) == [] for j in adv.chosen)
    q = cand.ref["qpos"].copy()
    q[2] = 3.1
    assert any("wrist" in a or "wrist" in b for a, b in collide(q))
    # infeasible candidates carry a reason, feasible ones none
    assert all((r == "") == f for r, f in zip(cand.reason, cand.feasible))


@pytest.mark.slow
def test_advice_monotone_and_json(scara_advice):
    from simcalib.studies.advise import advice_dict
    base, adv = scara_advice
    worst = [np.max(np.delete(np.r_[s[:3] / adv.tolerance_deg, s[3:] / adv.tolerance_m], 4))
             for s in adv.std_after]                     # vy: no SCARA motion determines it
    assert np.all(np.diff(worst) <= 1e-12)
    assert np.all(np.diff(adv.max_std_tol) <= 1e-12)
    # scara: X's translation along the vertical (the flange's y axis) is undetermined by
    # any motion a SCARA makes; the other five directions are determined
    assert np.isinf(adv.std_before[4]) and np.isinf(adv.std_after[:, 4]).all()
    assert np.isfinite(np.delete(adv.std_after, 4, axis=1)).all()
    out = json.loads(json.dumps(advice_dict(base, adv), allow_nan=False))
    # scara: the arm's DH error (robot_fk flange) and the map / calibration of the ArUco
    # wrist camera are weighed in the choice and in the predicted sigma
    assert out["systematic_parameters"] > 24 and "G G^T" in out["criterion"]
    assert base.pose_error_basis is not None and base.sources["cam_a"] == "robot_fk"
    Ba = base.pose_error_basis[0]                # the flange: the DH columns only
    from simcalib.pipeline.uncertainty_inputs import basis_layout
    lay = basis_layout(base.truth.world)
    assert np.any(Ba[:, :, lay["dh"]]) and not np.any(np.delete(Ba, np.r_[lay["dh"]], 2))
    assert len(out["motions"]) == 3
    assert set(out["motions"][0]["camera_motions"]) == {"cam_a", "cam_b"}
    assert len(out["motions"][0]["joint_targets_rad"]) == 6
    # what the predicted sigma after the stops is made of: the sources of the scara rig
    # (robot_fk flange: DH table; ArUco wrist camera b: map and calibration), shares of
    # each axis's variance summing to one, and the largest axis named with its fix
    lb = out["limited_by"]
    assert set(lb["shares"]) <= {"white noise", "marker map", "calibration of cam_b",
                                 "DH table of the arm"}
    assert "DH table of the arm" in lb["shares"] and "calibration of cam_a" not in lb["shares"]
    for axis, shares in lb["per_axis"].items():
        assert abs(sum(shares.values()) - 1.0) < 1e-9, axis
    std = adv.std_after[-1]
    in_tol = np.r_[std[:3] / adv.tolerance_deg, std[3:] / adv.tolerance_m]
    in_tol[4] = -np.inf                                   # vy: left to cannot_help
    assert lb["axis"] == ["wx_deg", "wy_deg", "wz_deg", "vx_m", "vy_m", "vz_m"][
        int(np.argmax(in_tol))]
    assert lb["dominant"] == max(lb["shares"], key=lb["shares"].get)
    assert "lower it" in lb["statement"] and lb["axis"] in lb["statement"]
    # the planner's own expectation: its chain against random chains of the same candidates
    eg = out["expected_gain"]
    assert eg["stops"] == len(out["motions"]) and eg["chains"] == adv.random_chains.shape[0]
    assert adv.random_chains_std.shape == (eg["chains"], 6)
    assert set(adv.random_chains.ravel()) <= set(np.flatnonzero(adv.candidates.feasible))
    assert eg["advised_max_std_cm"] == pytest.approx(100 * std[[3, 5]].max())
    assert eg["advised_max_std_cm"] < eg["random_max_std_cm_median"]
    assert eg["advised_max_std_deg"] < eg["random_max_std_deg_median"]


@pytest.mark.slow
def test_scara_advice_proposes_only_moves_a_scara_can_make(scara_advice):
    """scara: the UR5e stands in for a SCARA (``world.arm.motions: scara``): every candidate
    (the advice's and the random baseline's) and every advised stop turns the flange about
    the vertical only; the advice predicts finite 1-sigma on the five directions such
    motions determine and names the sixth (X's translation along the vertical) as
    undetermined, with its fix; the console says each stop is a motion from the previous
    stop (the first from the reference)."""
    import mujoco
    from simcalib.geometry import rotvec_from_matrix
    from simcalib.studies.advise import advice_dict
    from simcalib.studies.advise.advisor import random_baseline_candidates
    from simcalib.studies.advise.console import advice_lines
    from simcalib.studies.advise.information import AXES
    base, adv = scara_advice
    assert base.cfg.world.arm.motions == "scara"
    cand = adv.candidates
    for c in (cand, random_baseline_candidates(base, 20)):
        assert np.allclose(c.rotvec_world_rad[:, :2], 0.0)
        assert np.abs(c.rotvec_world_rad[:, 2]).min() >= np.radians(5.0) - 1e-12
    # the flange at each advised stop (forward kinematics of its joint targets) is the
    # reference flange turned about the vertical: no tilt beyond the IK's tolerance
    world = base.truth.world
    m, d = world.model, mujoco.MjData(world.model)
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.scene.mount_site)
    R_ref = cand.ref["T_world_target"][:3, :3]
    for j in adv.chosen:
        d.qpos[:] = cand.qpos[j]
        mujoco.mj_kinematics(m, d)
        rv = rotvec_from_matrix(d.site_xmat[sid].reshape(3, 3) @ R_ref.T)
        assert np.hypot(rv[0], rv[1]) <= 2 * world.config.ik.fail_rot_rad
        assert abs(rv[2]) >= np.radians(4.0)
    # undetermined: X's translation along the vertical, seen from camera a (the flange)
    up_a = cand.ref["T_world_cam"]["cam_a"][:3, :3].T @ np.array([0.0, 0.0, 1.0])
    assert len(adv.cannot_help) == 1
    h = adv.cannot_help[0]
    assert h["kind"] == "translation" and abs(np.dot(h["translation_dir_a"], up_a)) > 0.99
    assert "prior" in h["fix"] and "SCARA" in h["fix"]
    k = 3 + int(np.argmax(np.abs(up_a)))
    for s in (adv.std_before, *adv.std_after):
        assert np.isinf(s[k]) and np.isfinite(np.delete(s, k)).all()
    out = json.loads(json.dumps(advice_dict(base, adv), allow_nan=False))
    for mo in out["motions"]:
        assert mo["predicted_std_after"][AXES[k]] is None
        assert all(mo["predicted_std_after"][a] > 0 for a in AXES if a != AXES[k])
        rv = mo["target_motion"]["rotvec_world_deg"]
        assert np.hypot(rv[0], rv[1]) <= 1e-6 * max(abs(rv[2]), 1.0)
    text = "\n".join(advice_lines(out))
    assert "each stop is a motion from the previous stop (stop 1: from the reference" in text
    assert "stop 1 (from the reference stop): flange turns" in text
    assert "stop 2 (from stop 1): flange turns" in text and "deg about the vertical" in text
    assert "cannot help: translation of X along" in text


@pytest.mark.slow
def test_cart_states_what_it_cannot_help():
    from simcalib.studies.advise import advise, baseline
    from simcalib.pipeline.scenario import load_config
    # the realistic camera's marker map error makes the recorded motions look slightly
    # tilted (~0.1 deg): the statement must not depend on such spurious information
    cfg = load_config("planar", BASE + ["world.duration_s=12", "camera.width=320",
                                         "camera.height=240"])
    base = baseline(cfg)
    adv = advise(base, 2, n_candidates=40, render=False)
    assert adv.candidates.platform == "cart"
    assert np.allclose(adv.candidates.rotvec_world_rad[:, :2], 0)   # drivable: yaw only
    assert len(adv.cannot_help) >= 1
    h = adv.cannot_help[0]
    # the vertical, seen from camera a
    T_wa = base.truth.streams["cam_a"].T_world_cam[0]
    up_a = T_wa[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    assert h["kind"] == "translation" and abs(np.dot(h["translation_dir_a"], up_a)) > 0.9
    assert "prior" in h["fix"]
    # what limits the determined axes never names the undeterminable one (cannot_help has it)
    from simcalib.studies.advise.systematic import cannot_help_axes
    excluded = cannot_help_axes(adv.cannot_help)
    vert = ["vx_m", "vy_m", "vz_m"][int(np.argmax(np.abs(up_a)))]
    assert vert in excluded
    if adv.limited_by:
        assert adv.limited_by["axis"] not in excluded
        assert "cannot_help" in adv.limited_by["statement"]
    # the predicted 1-sigma: the vertical undetermined, the other axes finite
    k = ["vx_m", "vy_m", "vz_m"].index(vert) + 3
    assert np.isinf(adv.std_after[-1][k])
    assert np.isfinite(np.delete(adv.std_after[-1], k)).all()
    # the model's floor: on the directions the cart determines (the vertical left out)
    from simcalib.studies.advise.bounds import choice_floor
    fl = choice_floor(base, adv, n_starts=1, n_random=40, n_chains=10)
    for u in ("deg", "cm"):
        assert 0 < fl[f"floor_expected_{u}"] <= fl[f"advised_expected_{u}"] * (1 + 1e-12)


@pytest.mark.slow
def test_small_verification_run(tmp_path, capsys):
    from simcalib.cli import main
    code = main(["advise", "scenario=linear", "world.platform=arm", "k=2", "verify=true",
                 "seeds=2", "candidates=30", "hindsight=true", "floor=true",
                 f"output={tmp_path}", *SMALL,
                 "camera.width=320", "camera.height=240"])
    assert code == 0
    out = json.loads((tmp_path / "advice.json").read_text())
    ver = out["verification"]
    assert ver["advised"]["success"] and ver["advised"]["stops_measured"] >= 1
    assert len(ver["random"]) == 2 and len(ver["random_joint"]) == 2
    assert ver["motion_size"]["random_joint"]["rotation_deg"] > 0
    # the third baseline draws from the advice's own candidates
    assert len(ver["random_wide"]) == 2
    assert all(0 <= j < out["candidates"]["drawn"] for r in ver["random_wide"]
               for j in r["stops"])
    assert set(ver["ratio_advised_to_random_wide_median"]) == {"rotation_error_deg",
                                                               "translation_error_cm"}
    # the linear path leaves X's translation undetermined; two advised stops determine it
    assert ver["baseline"]["verdict"] != "determined"
    assert ver["advised"]["translation_error_cm"] < ver["baseline"]["translation_error_cm"]
    assert (tmp_path / "advice.rrd").is_file()
    printed = capsys.readouterr().out
    assert "advised median / random (jog ranges) median" in printed
    assert "advised median / random from the advice's candidates median" in printed
    # the hindsight bound: k feasible stops of the advice's candidates, picked by the truth
    hs = ver["hindsight"]
    assert hs["success"] and len(hs["stops"]) == 2 and len(set(hs["stops"])) == 2
    assert hs["translation_error_cm"] < ver["baseline"]["translation_error_cm"]
    assert set(ver["ratio_hindsight_to_random_median"]) == {"rotation_error_deg",
                                                            "translation_error_cm"}
    assert "hindsight (stops picked knowing the true X" in printed
    # the model's floor: never above the advised stops' expected error, beside random's
    fl = out["choice_floor"]
    assert fl["stops"] == 2 and fl["floor_expected_cm"] <= fl["advised_expected_cm"]
    assert fl["random_expected_cm"] > 0 and "model floor (expected RMS error" in printed


def test_exchange_refinement_never_worse_than_greedy_and_noise_scale_steers():
    rng = np.random.default_rng(3)
    X = _X()
    Cb = _motions(rng, 30, axes=np.tile([0.0, 0.0, 1.0], (30, 1)))
    Fb = info.motion_information(Cb, np.linalg.inv(X) @ Cb @ X, X, 0.005, 0.001).sum(0)
    M = _motions(rng, 60)
    g0, a0 = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 4, refine=False)
    g1, a1 = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 4, refine=True)
    assert g1.criterion[-1] <= g0.criterion[-1] * (1 + 1e-12)
    assert np.all(np.diff(g1.criterion) <= 1e-12) and len(set(g1.order.tolist())) == 4
    np.testing.assert_allclose(Fb + a1.sum(0), Fb + a1.sum(0).T)     # symmetric
    # a stop 100x noisier than every other is never chosen
    sc = np.ones(60)
    sc[g1.order[0]] = 100.0
    g2, _ = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 4, noise_scale=sc)
    assert g1.order[0] not in g2.order
    with pytest.raises(ValueError, match="noise_scale"):
        pl.greedy_chain(Fb, M, X, 0.005, 0.001, 2, noise_scale=np.zeros(60))


def test_candidate_ranges_jog_and_wide(scara_advice):
    from simcalib.studies.advise.feasibility import RANGES, candidates
    base, adv = scara_advice
    world = _six_dof(base.truth.world)
    ang = {}
    for r in ("jog", "wide"):
        c = candidates(world, 60, np.random.default_rng(1), ranges=r)
        ang[r] = np.degrees(np.linalg.norm(c.rotvec_world_rad, axis=1))
        move = np.linalg.norm(c.dp_world_m, axis=1)
        max_deg, max_m = RANGES[r]["arm"]
        assert ang[r].min() >= 5.0 - 1e-9 and ang[r].max() <= max_deg + 1e-9
        assert move.max() <= max_m + 1e-12
    assert ang["wide"].max() > RANGES["jog"]["arm"][0]      # the planner looks farther
    # the advice's candidates are drawn over the wide ranges by default
    assert np.degrees(np.linalg.norm(adv.candidates.rotvec_world_rad, axis=1)).max() > 40.0
    with pytest.raises(ValueError, match="ranges must be one of"):
        candidates(world, 2, np.random.default_rng(0), ranges="far")


def test_candidates_count_the_markers_the_lens_shows(scara_advice):
    """The candidates' marker check and view quality are judged in the image the camera
    sees: the scenario's barrel lens shows markers past the pinhole image's edge (as the
    render does), and the advice counts them."""
    from simcalib.studies.advise.feasibility import lens_distortion
    from simcalib.studies.advise.feasibility import candidates, view_quality
    from simcalib.world.layout import visible_markers
    base, adv = scara_advice
    world = _six_dof(base.truth.world)
    lens = lens_distortion(base.cfg)
    assert lens is not None and np.any(lens != 0)              # the realistic preset's lens
    cams = base.aruco_cameras
    pin = candidates(world, 60, np.random.default_rng(3), aruco_cameras=cams, ranges="wide")
    dis = candidates(world, 60, np.random.default_rng(3), aruco_cameras=cams, ranges="wide",
                     distortion=lens)
    np.testing.assert_array_equal(pin.T_world_target, dis.T_world_target)  # same draws
    for c in cams:
        assert dis.visible[c].sum() > pin.visible[c].sum()      # the lens shows more
        np.testing.assert_array_equal(adv.candidates.visible[c], visible_markers(
            world.marker_field, adv.candidates.T_world_cam[c], world.intrinsics[c],
            distortion=lens).sum(axis=1))                  # the advice's (SCARA) candidates
        q_pin = view_quality(world, dis.T_world_cam[c], c)
        q_lens = view_quality(world, dis.T_world_cam[c], c, lens)
        assert q_pin.shape == q_lens.shape == (60,) and not np.allclose(q_pin, q_lens)
    # a stop the pinhole check refuses for too few markers, the lens admits (and never
    # the reverse for that reason alone)
    few = [i for i, r in enumerate(pin.reason) if "markers" in r]
    assert any(dis.feasible[i] for i in few)
    zero = candidates(world, 60, np.random.default_rng(3), aruco_cameras=cams, ranges="wide",
                      distortion=np.zeros(5))                  # no lens: the pinhole image
    for c in cams:
        np.testing.assert_array_equal(zero.visible[c], pin.visible[c])


def test_a_stop_the_render_never_measures_is_never_advised(scara_advice):
    """When every round of the render check finds an unmeasured stop (here: the last stop
    of each chain it is shown), the advice is chosen among the stops the renders did
    measure: no advised stop is one the render rejected, and each has its marker count."""
    from types import SimpleNamespace
    from simcalib.studies.advise.advisor import advise_motions
    base, _ = scara_advice
    shown = []

    def render_check(cand, order):
        shown.append([int(j) for j in order])
        frames = [0] + list(range(1, len(order)))            # the last stop: no pose
        return {c: SimpleNamespace(frame_index=np.array(frames),
                                   info={"n_markers": np.full(len(frames), 7)})
                for c in base.aruco_cameras}

    adv = advise_motions(base.truth.world, base.C, base.H, base.X, 3,
                         rng=np.random.default_rng([5, 13]), alpha=base.alpha,
                         n_candidates=40, aruco_cameras=base.aruco_cameras,
                         render_check=render_check)
    assert len(shown) == 4 and adv.rejected_by_render          # every round rejected one
    measured = {j for order in shown for j in order[:-1]}
    assert adv.chosen.size >= 1 and set(adv.chosen.tolist()) <= measured
    assert not set(adv.chosen.tolist()) & set(adv.rejected_by_render)
    for c in base.aruco_cameras:
        assert adv.render_check[c] == [7] * adv.chosen.size


def test_joint_jog_baseline_stops_are_feasible(scara_advice):
    from simcalib.studies.advise.feasibility import joint_candidates, view_quality
    base, adv = scara_advice
    with pytest.raises(ValueError, match="joint_candidates needs a 6-DoF arm"):
        joint_candidates(base.truth.world, 2, np.random.default_rng(0))  # a SCARA's tilts
    world = _six_dof(base.truth.world)
    jc = joint_candidates(world, 12, np.random.default_rng(0),
                          aruco_cameras=base.aruco_cameras, max_joint_deg=15.0)
    m = world.model
    lim = m.jnt_limited.astype(bool)
    d = np.abs(jc.qpos - jc.ref["qpos"][None])
    assert d.max() <= np.deg2rad(15.0) + 1e-12 and d.max() > 0
    for j in np.flatnonzero(jc.feasible):
        q = jc.qpos[j][m.jnt_qposadr]
        assert (~lim | ((q >= m.jnt_range[:, 0]) & (q <= m.jnt_range[:, 1]))).all()
    assert all((r == "") == f for r, f in zip(jc.reason, jc.feasible))
    for c in base.aruco_cameras:
        q = view_quality(world, jc.T_world_cam[c], c)
        assert q.shape == (12,) and (q >= 0).all()
        assert (q[jc.visible[c] == 0] == 0).all()
    with pytest.raises(ValueError, match="max_joint_deg"):
        joint_candidates(world, 2, np.random.default_rng(0), max_joint_deg=0)


def test_stops_are_measured_at_rest():
    """Stop and go: a stop's frame is one instantaneous render (no sub-frames that would
    interpolate the pose towards the next stop); every other camera effect is kept."""
    from simcalib.studies.advise.stops import stop_config
    from simcalib.pipeline.scenario import load_config
    cfg = load_config("3d", ["vision.preset=realistic"])
    assert cfg.vision.effects().timed                   # realistic: blur, rolling shutter
    at_rest = stop_config(cfg)
    eff, eff0 = at_rest.vision.effects(), cfg.vision.effects()
    assert not eff.timed and at_rest.workers == 1
    assert eff.distortion == eff0.distortion and eff.map_position_std_m > 0
    assert eff.exposure_s == eff0.exposure_s and eff.jpeg_quality == eff0.jpeg_quality


def test_average_stop_frames_takes_the_mean_pose_of_each_stop():
    from simcalib.studies.advise.stops import average_stop_frames
    from simcalib.geometry import matrix_from_rotvec
    from simcalib.streams import PoseStream
    truth = np.stack([np.eye(4)] * 3)
    truth[:, :3, 3] = [[0, 0, 1], [0.5, 0, 1], [0, 0.5, 1]]
    truth[1, :3, :3] = matrix_from_rotvec(np.array([0.0, 0.0, 0.7]))
    stop_of = np.repeat(np.arange(3), 4)                  # 4 frames at rest per stop
    fi = np.array([0, 1, 2, 3, 4, 6])                     # stop 1 lost two, stop 2 all
    d = 0.01
    E = [np.array([d, 0, 0]), np.array([-d, 0, 0]), np.array([0, d, 0]), np.array([0, -d, 0]),
         np.array([0, 0, d]), np.array([0, 0, -d])]
    T = truth[stop_of[fi]].copy()
    for k, e in enumerate(E):                            # symmetric errors: mean = truth
        T[k, :3, :3] = T[k, :3, :3] @ matrix_from_rotvec(e)
        T[k, :3, 3] += e
    s = PoseStream("cam_b", "aruco", fi, 0.1 * fi, T, 12,
                   info={"n_markers": np.array([5, 6, 7, 8, 9, 10])})
    out = average_stop_frames(s, stop_of)
    assert out.frame_index.tolist() == [0, 1] and out.n_frames == 3
    assert out.info["frames_averaged"].tolist() == [4, 2]
    assert out.info["n_markers"].tolist() == [5, 9]
    assert np.allclose(out.T_world_cam, truth[:2], atol=1e-4)
    assert np.allclose(out.timestamp_s, [0.0, 0.4])


@pytest.mark.slow
def test_stops_measured_with_several_frames_at_rest(scara_advice):
    """frames_per_stop: each stop's pose is the mean of its frames, each with its own noise
    (the frames differ), stop indices as with one frame."""
    from simcalib.studies.advise.stops import execute_stops
    base, adv = scara_advice
    idx = adv.chosen[:2]
    one = execute_stops(base.truth, base.cfg, adv.candidates, idx, np.random.default_rng(1))
    avg = execute_stops(base.truth, base.cfg, adv.candidates, idx, np.random.default_rng(1),
                        frames_per_stop=4)
    for cam in ("cam_a", "cam_b"):
        assert set(avg[cam].frame_index) == set(one[cam].frame_index)
    cam = base.aruco_cameras[0]
    assert (avg[cam].info["frames_averaged"] >= 1).all()
    assert (avg[cam].info["frames_averaged"] <= 4).all()
    assert not np.allclose(avg[cam].T_world_cam, one[cam].T_world_cam, atol=1e-9)
    with pytest.raises(ValueError, match="frames_per_stop must be an integer >= 1"):
        execute_stops(base.truth, base.cfg, adv.candidates, idx, np.random.default_rng(1),
                      frames_per_stop=0)


@pytest.mark.slow
def test_stops_are_measured_by_the_recorded_runs_rig(scara_advice, monkeypatch):
    """The stops see the recorded run's marker map survey and camera calibrations (the same
    rig), with their own per-frame noise: the rig number the stops' ArUco measurement uses
    is the one the recorded run's drew."""
    import simcalib.sources.vision.stream as vision
    from simcalib.pipeline import stages as pipeline
    from simcalib.studies.advise.stops import execute_stops
    base, adv = scara_advice
    seen = []
    real = vision.visual_streams

    def spy(world, cfg, rng, *a, rig_entropy=None, **kw):
        seen.append(vision.rig_entropy_of(rng) if rig_entropy is None else rig_entropy)
        return real(world, cfg, rng, *a, rig_entropy=rig_entropy, **kw)

    monkeypatch.setattr(vision, "visual_streams", spy)
    pipeline.state_through_pairs(base.cfg)                       # the recorded run
    for s in (1, 2):
        execute_stops(base.truth, base.cfg, adv.candidates, adv.chosen[:1],
                      np.random.default_rng(s))
    assert len(seen) == 3 and seen[0] == seen[1] == seen[2]


@pytest.mark.slow
def test_hindsight_stops_are_the_best_by_the_truth():
    """The hindsight bound picks, among the measured candidates, the stop whose motion gives
    dqopt the smallest scored error against the true X — checked by measuring and solving
    every feasible candidate on its own (ideal images: a pose's measurement does not depend
    on its frame number)."""
    import simcalib
    from simcalib.studies.advise import advise, baseline
    from simcalib.studies.advise import stops as fz
    from simcalib.studies.advise.bounds import hindsight_stops
    from simcalib.pipeline.scenario import load_config
    from simcalib.geometry import rotation_error_rad
    cfg = load_config("linear", SMALL + ["world.platform=arm", "vision.preset=ideal",
                                         "camera.width=320", "camera.height=240"])
    base = baseline(cfg)
    cand = advise(base, 1, n_candidates=12, render=False).candidates
    scale = (0.05, 0.2)
    h = hindsight_stops(base, cand, 1, np.random.default_rng(0), scale=scale)
    assert h["success"] and len(h["stops"]) == 1 and cand.feasible[h["stops"][0]]
    scores = {}
    for j in np.flatnonzero(cand.feasible):
        C, H, got = fz.stop_motions(fz.execute_stops(base.truth, base.cfg, cand, [j],
                                                     np.random.default_rng(1)))
        if got.size:
            X = simcalib.solve(np.concatenate([base.C, C]), np.concatenate([base.H, H]),
                               method="dqopt", alpha=base.alpha).X
            r = np.rad2deg(rotation_error_rad(X, base.truth.X_true))
            t = 100 * np.linalg.norm(X[:3, 3] - base.truth.X_true[:3, 3])
            scores[int(j)] = (max(r / scale[0], t / scale[1]), r, t)
    best = min(scores, key=lambda j: scores[j][0])
    assert h["stops"][0] == best
    np.testing.assert_allclose([h["rotation_error_deg"], h["translation_error_cm"]],
                               scores[best][1:], rtol=1e-6, atol=1e-9)
    # the ranking diagnostic: each one-stop chain's actual error is the one just solved
    # (each measured stop three times: chains may share stops, and >= 10 chains are ranked)
    feas = np.repeat(sorted(scores), 3)
    assert len(scores) >= 4
    chains = feas[:, None]
    pred = np.zeros((feas.size, 6))
    pred[:, 0] = [scores[j][1] for j in feas]              # predicted = actual (rotation)
    pred[:, 3] = [1.0 / scores[j][2] for j in feas]        # reversed ranking (translation)
    hr = hindsight_stops(base, cand, 1, np.random.default_rng(0), scale=scale,
                         chains=chains, chains_std=pred)
    rk = hr["ranking"]
    assert rk["chains"] == feas.size
    assert rk["spearman_rotation"] == pytest.approx(1.0)
    assert rk["spearman_translation"] == pytest.approx(-1.0)
    assert rk["best_tenth_over_all_rotation"] < 1.0 < rk["best_tenth_over_all_translation"]
    with pytest.raises(ValueError, match="scale must be"):
        hindsight_stops(base, cand, 1, np.random.default_rng(0), scale=(0.0, 1.0))


def test_variance_shares_split_the_covariance_by_source():
    rng = np.random.default_rng(4)
    A = rng.standard_normal((6, 6))
    F = A @ A.T * 1e4 + 1e3 * np.eye(6)
    G = rng.standard_normal((6, 5)) * 30
    labels = ["map", "map", "cal", "dh", "cal"]
    shares, names = info.variance_shares(F, G, labels)
    assert names == ["white noise", "map", "cal", "dh"]
    np.testing.assert_allclose(shares.sum(axis=1), 1.0)
    # the parts add up to the diagonal of F^-1 + F^-1 G G^T F^-1 (systematic_std, squared)
    Fi = np.linalg.inv(F)
    var = np.diag(Fi + Fi @ G @ G.T @ Fi)
    s = info.systematic_std(F, G)
    np.testing.assert_allclose(np.r_[np.radians(s[:3]), s[3:]] ** 2, var, rtol=1e-9)
    # the map's share is its columns' part of that diagonal
    FG = Fi @ G[:, :2]
    np.testing.assert_allclose(shares[:, 1], np.sum(FG * FG, axis=1) / var, rtol=1e-9)
    # without systematic columns everything is white noise; bad shapes are named
    sh0, n0 = info.variance_shares(F, np.zeros((6, 0)), [])
    assert n0 == ["white noise"] and np.allclose(sh0, 1.0)
    with pytest.raises(ValueError, match="P group labels"):
        info.variance_shares(F, G, labels[:3])


@pytest.mark.slow
def test_choice_floor_is_no_worse_than_the_advice_and_states_its_search(scara_advice):
    """The model's floor: its search starts from the advised chain, so it is never above
    the advice's expected error; its chains are usable candidates of k distinct stops;
    the ratios are the expected errors over the random baseline's; the advised expected
    error is the model's for the chosen chain."""
    from simcalib.studies.advise import bounds as A
    from simcalib.studies.advise import planner as pl
    base, adv = scara_advice
    fl = A.choice_floor(base, adv, n_starts=2, n_random=60, n_chains=20)
    assert fl["stops"] == adv.k == 3 and fl["starts"] == 3 and fl["random_chains"] == 20
    for blk, u in (("rotation", "deg"), ("translation", "cm")):
        assert 0 < fl[f"floor_expected_{u}"] <= fl[f"advised_expected_{u}"] * (1 + 1e-12)
        assert fl[f"floor_expected_{u}"] == pytest.approx(min(fl[f"floor_per_start_{u}"]))
        assert fl[f"ratio_floor_{blk}"] == pytest.approx(
            fl[f"floor_expected_{u}"] / fl[f"random_expected_{u}"])
        assert fl[f"ratio_advised_{blk}"] == pytest.approx(
            fl[f"advised_expected_{u}"] / fl[f"random_expected_{u}"])
        ch = fl["floor_chains"][blk]
        assert len(set(ch)) == 3 and adv.candidates.feasible[ch].all()
        assert not set(ch) & set(adv.rejected_by_render)
    # the advised expected error: the planner's model of the chosen chain (white noise
    # alone, as a lower bound: the shared errors only add)
    F, G = pl.chain_information(adv.F_base, adv.candidates.motion["cam_a"], adv.X,
                                *adv.noise, adv.chosen[None], noise_scale=adv.noise_scale)
    white = pl.expected_errors(F, G, undetermined=adv.undetermined)[0]   # vy left out
    assert adv.undetermined is not None and np.isfinite(white).all()
    assert fl["advised_expected_deg"] >= white[0] and fl["advised_expected_cm"] >= 100 * white[1]
    assert A.choice_floor(base, dataclasses.replace(adv, chosen=adv.chosen[:2])) == {}


@pytest.mark.parametrize("scenario, says", [
    ("car", "advice supports world.platform 'arm' or 'cart'; scenario 'car' has 'car'"),
    ("random", "advice needs a simulated platform (kind 'sim' on arm or cart); scenario "
               "'random' has kind 'synthetic'")])
def test_advice_refuses_a_platform_it_cannot_move_before_any_work(scenario, says, capsys,
                                                                  monkeypatch, tmp_path):
    """A usage error (exit 2) with what was received and what is allowed, before the
    recorded run is simulated."""
    from simcalib.pipeline import stages as pipeline
    from simcalib.studies.advise import advisor
    from simcalib.cli import main
    from simcalib.pipeline.scenario import load_config
    from simcalib.errors import ConfigError

    def no_work(cfg):
        raise AssertionError("the recorded run must not start")
    monkeypatch.setattr(pipeline, "state_through_pairs", no_work)
    assert main(["advise", f"scenario={scenario}", f"output={tmp_path}"]) == 2
    assert says in capsys.readouterr().err
    with pytest.raises(ConfigError, match="advice"):
        advisor.baseline(load_config(scenario, ["progress=false"]))
