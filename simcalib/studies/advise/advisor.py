"""Advice for a scenario's run, and its verification in simulation.

``baseline(cfg)`` runs the world, streams and pairs stages of :func:`simcalib.run` (the same
seeds, so the same data) and solves dqopt; ``advise(base, k)`` proposes the next ``k`` stops
(:mod:`simcalib.studies.advise.feasibility`, :mod:`simcalib.studies.advise.planner`); ``verify(base, adv)``
executes them in the simulator (render, detect, solve) and compares with ``k`` random
feasible stops over several seeds. :func:`advise_motions` is the core for motions from any
source (e.g. pose streams read by :mod:`simcalib.importers`) given a world that models
the platform.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from simcalib.studies.advise import feasibility as fz
from simcalib.studies.advise import planner as pl

__all__ = ["Baseline", "StopPlan", "Advice", "Verification", "baseline", "advise",
           "advise_motions", "verify", "solve_errors", "advice_dict", "recorded_information",
           "determined_message", "predicted_along_chain", "check_when_determined",
           "hindsight_stops", "limited_by", "choice_floor", "random_baseline_candidates",
           "check_advisable", "PLATFORMS"]

AXES = ("wx_deg", "wy_deg", "wz_deg", "vx_m", "vy_m", "vz_m")


@dataclass(frozen=True)
class Baseline:
    """The recorded run: ``cfg``, ``truth`` (GroundTruth), ``C``, ``H`` (its motions),
    ``X`` (the estimate advice linearises at: dqopt, with the prior when the config has
    one), ``X_noprior`` (dqopt alone), ``alpha``, ``aruco_cameras``, ``timing_s``,
    ``pose_error_basis``."""
    cfg: object
    truth: object
    C: np.ndarray
    H: np.ndarray
    X: np.ndarray
    X_noprior: np.ndarray
    alpha: float
    aruco_cameras: tuple
    prior: object = None
    timing_s: dict = field(default_factory=dict)
    #: ``(Ba, Bb, pose_pairs)``: the systematic pose errors of the recorded datapoints
    #: (:func:`simcalib.pipeline.uncertainty_inputs.pose_error_basis`, full layout) and the
    #: motions' datapoint pairs; None without such errors (ArUco: map / calibration; robot_fk:
    #: DH table)
    pose_error_basis: tuple | None = None
    sources: dict = field(default_factory=dict)   # camera -> pose source name


#: the platforms advice can move (feasibility.candidates)
PLATFORMS = ("arm", "cart")


def check_advisable(cfg) -> None:
    """ConfigError, before any work, unless ``cfg`` (a ScenarioConfig) simulates a
    platform advice can move: kind ``sim`` on one of :data:`PLATFORMS`."""
    from simcalib.errors import ConfigError
    if cfg.kind != "sim":
        raise ConfigError(f"advice needs a simulated platform (kind 'sim' on "
                          f"{' or '.join(PLATFORMS)}); scenario {cfg.scenario!r} has kind "
                          f"{cfg.kind!r}")
    if cfg.world.platform not in PLATFORMS:
        raise ConfigError(f"advice supports world.platform {' or '.join(map(repr, PLATFORMS))}"
                          f"; scenario {cfg.scenario!r} has {cfg.world.platform!r} (its "
                          f"motions come from a physics simulation, not from stops a planner "
                          f"can choose)")


def baseline(cfg) -> Baseline:
    """Run the stages ``world``, ``streams``, ``pairs`` of ``cfg`` (a ScenarioConfig) and
    solve dqopt at the run's alpha (``solver_stage.choose_run_alpha``), plus its prior when
    ``cfg.prior.enabled``; :func:`check_advisable` first."""
    from simcalib.solvers.api import solve
    from simcalib.pipeline import solver_stage, uncertainty_inputs
    from simcalib.pipeline.stages import state_through_pairs
    from simcalib.sources import camera_sources
    check_advisable(cfg)
    t0 = time.perf_counter()
    st = state_through_pairs(cfg)
    C, H = st.pairs.C, st.pairs.H
    alpha = solver_stage.choose_run_alpha(cfg, C, H)["alpha"]   # as the run's headline: no truth
    sol = solve(C, H, method="dqopt", alpha=alpha)
    X0 = np.asarray(sol.X, dtype=np.float64)
    X = X0
    prior = None
    if cfg.prior.enabled:
        prior, _ = solver_stage.run_prior(st)
        sp = solve(C, H, method="dqopt", alpha=alpha, prior=prior)
        if sp.success and np.isfinite(sp.X).all():
            X = np.asarray(sp.X, dtype=np.float64)
    if not np.isfinite(X).all():
        raise ValueError(f"dqopt failed on the recorded run of {cfg.scenario!r}: "
                         f"{sol.solver_message}")
    srcs = camera_sources(cfg, st.truth.kind)
    aruco = tuple(c for c, s in srcs.items() if s == "aruco")
    basis = uncertainty_inputs.pose_error_basis(st, compress=False)
    pairs = uncertainty_inputs.pose_pairs(st)
    return Baseline(cfg, st.truth, C, H, X, X0, alpha, aruco, prior,
                    {"baseline": time.perf_counter() - t0},
                    None if basis is None or pairs is None else (*basis, pairs), dict(srcs))


@dataclass(frozen=True)
class StopPlan:
    """What any advice holds: ``chosen`` (candidate indices, in the order to visit them),
    ``std_before`` (6,) and ``std_after`` (k, 6): predicted 1-sigma per axis (deg, deg,
    deg, m, m, m) with the recorded motions and after each added stop; ``max_std_tol``:
    largest 1-sigma in tolerance units per step; ``criterion`` per step; ``noise``
    (sigma_r_rad, sigma_t_m) fitted to the recorded motions; ``cannot_help``: directions
    no feasible motion determines (with the fix); ``X``: the estimate it linearises at."""
    k: int
    chosen: np.ndarray
    std_before: np.ndarray
    std_after: np.ndarray
    max_std_tol: np.ndarray
    criterion: np.ndarray
    noise: tuple
    tolerance_deg: float
    tolerance_m: float
    cannot_help: list
    X: np.ndarray
    timing_s: dict


@dataclass(frozen=True)
class Advice(StopPlan):
    """A :class:`StopPlan` for a simulated platform: ``candidates`` (all drawn, with
    feasibility), ``render_check``: camera -> markers detected per chosen stop;
    ``rejected_by_render``: candidates dropped by it; ``F_base``, ``F_cand``: the recorded
    and the candidates' information."""
    candidates: fz.Candidates = None
    render_check: dict = field(default_factory=dict)
    rejected_by_render: tuple = ()
    F_base: np.ndarray | None = None
    F_cand: np.ndarray | None = None
    message: str = ""
    noise_scale: np.ndarray | None = None
    systematic_parameters: int = 0     # shared pose-error parameters the choice weighed
    #: what the predicted uncertainty after the stops is made of (:func:`limited_by`)
    limited_by: dict = field(default_factory=dict)
    #: ``(n, k)`` chains of ``k`` stops drawn at random from the same feasible candidates
    #: and ``(n, 6)`` their predicted 1-sigma per axis (:func:`random_chains`)
    random_chains: np.ndarray | None = None
    random_chains_std: np.ndarray | None = None


WHEN_DETERMINED = ("stop", "advise")
#: candidate stops the planner draws by default (advice for k = 5 in ~10 s on 2 cores)
N_CANDIDATES = 1000


def advise_motions(world, C, H, X, k: int = 5, *, rng: np.random.Generator, alpha: float = 1.0,
                   n_candidates: int = N_CANDIDATES, aruco_cameras=(), tolerance_deg: float = 1.0,
                   tolerance_m: float = 0.01, render_check=None, when_determined: str = "advise",
                   view_weighting: bool = True, refine: bool = True, pose_error_basis=None,
                   run_cfg=None, sources=None, ranges: str = "wide", **cand_kw) -> Advice:
    """Propose ``k`` stops for a platform modelled by ``world`` given recorded motions
    ``C``, ``H`` (N, 4, 4) and the estimate ``X``. ``render_check(cand, idx) -> {camera:
    PoseStream}`` (optional) renders and detects the chosen stops; those not measured by an
    ArUco camera are dropped and the choice repeated (at most 3 times). The candidates are
    ``n_candidates`` stops drawn by :func:`feasibility.candidates` over ``ranges`` (default
    ``"wide"``: the arm's flange rotated up to 90 deg and moved up to 30 cm; ``cand_kw``
    overrides the maxima); with ``run_cfg``, the ArUco cameras' markers are counted in the
    image their lens forms (:func:`lens_distortion`).

    ``when_determined``: when the recorded motions already determine every direction of X
    within the tolerance (largest predicted 1-sigma <= 1 tolerance), ``"advise"``
    (default) still proposes the ``k`` stops that lower it most and says so in
    ``message``; ``"stop"`` proposes none.

    ``view_weighting``: scale each candidate stop's pose-noise variance by how much worse
    (or better) the ArUco cameras' view of the markers is there than at the reference
    (:func:`feasibility.view_quality`, factor ``(q_ref / q)**2`` clipped to [1/4, 4], the
    worst camera); ``refine``: exchange passes after the greedy choice.

    ``pose_error_basis``: ``(Ba, Bb, pose_pairs)`` of the recorded datapoints (full layout of
    :func:`simcalib.pipeline.uncertainty_inputs.pose_error_basis`, ``compress=False``) with
    ``run_cfg`` (the run's ScenarioConfig) and ``sources`` (camera -> source name): the
    systematic pose
    errors (marker map and calibrations for ArUco cameras, the arm's DH table for
    ``robot_fk``) are then part of the choice — each candidate stop's error basis
    (:func:`simcalib.pipeline.uncertainty_inputs.stop_error_basis`, the markers the layout shows
    there), and the criterion that of the covariance with those shared errors
    (:func:`planner.greedy_chain`, ``systematic``); the predicted 1-sigma include them."""
    check_when_determined(when_determined)
    t0 = time.perf_counter()
    kw = dict(tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)
    s_r, s_t, F_base, L = recorded_information(C, H, X, alpha, **kw)
    t1 = time.perf_counter()
    lens = lens_distortion(run_cfg) if aruco_cameras else None
    cand = fz.candidates(world, n_candidates, rng, aruco_cameras=aruco_cameras, ranges=ranges,
                         **{"distortion": lens, **cand_kw})
    t2 = time.perf_counter()
    Cc, Hc = pl.predicted_motions(cand.motion["cam_a"], X)
    F_cand = pl.motion_information(Cc, Hc, X, s_r, s_t)
    scale = _view_noise_scale(world, cand, aruco_cameras, lens, view_weighting)
    sysm, groups = None, []
    if pose_error_basis is not None and run_cfg is not None and sources:
        sysm, groups = _systematic(world, cand, C, H, X, s_r, s_t, pose_error_basis,
                                   dict(sources), run_cfg)
    message, propose = determined_message(F_base, when_determined, **kw)
    feasible = cand.feasible.copy() if propose else np.zeros_like(cand.feasible)
    g, added, added_g, rejected, checked = _choose_render_checked(
        F_base, cand, X, s_r, s_t, k, feasible, scale, refine, sysm, render_check,
        aruco_cameras, kw)
    t3 = time.perf_counter()
    before, after = predicted_along_chain(F_base, added, added_g, sysm, L, **kw)
    cannot = pl.undeterminable(F_base, F_cand, feasible=cand.feasible, range_m=L, **kw)
    chains, chains_std = random_chains(F_base, cand.motion["cam_a"], X, s_r, s_t,
                                       _usable(cand, rejected), int(g.order.size), rng,
                                       noise_scale=scale, systematic=sysm, range_m=L, **kw)
    limit = {} if sysm is None else limited_by(
        F_base + added.sum(axis=0), sysm[0] + added_g.sum(axis=0), groups,
        after[-1] if len(after) else before, range_m=L, exclude=cannot_help_axes(cannot), **kw)
    return Advice(k=int(k), candidates=cand, chosen=g.order,
                  std_before=before, std_after=after, max_std_tol=g.max_std_tol,
                  criterion=g.criterion, noise=(s_r, s_t), tolerance_deg=tolerance_deg,
                  tolerance_m=tolerance_m, cannot_help=cannot, render_check=checked,
                  rejected_by_render=tuple(rejected), F_base=F_base, F_cand=F_cand, X=X,
                  message=message, noise_scale=scale,
                  systematic_parameters=0 if sysm is None else int(sysm[0].shape[1]),
                  limited_by=limit, random_chains=chains, random_chains_std=chains_std,
                  timing_s={"information": t1 - t0, "candidates": t2 - t1,
                            "choice_and_render_check": t3 - t2,
                            "total": time.perf_counter() - t0})


def _view_noise_scale(world, cand, aruco_cameras, lens, view_weighting: bool) -> np.ndarray:
    """``(N,)`` pose-noise variance factor of each candidate stop from the worst ArUco view."""
    scale = np.ones(cand.n)
    if view_weighting and aruco_cameras:
        for c in aruco_cameras:
            q_ref = fz.view_quality(world, cand.ref["T_world_cam"][c][None], c, lens)[0]
            q = fz.view_quality(world, cand.T_world_cam[c], c, lens)
            f = np.clip((q_ref / np.maximum(q, 1e-9)) ** 2, 0.25, 4.0)
            scale = np.maximum(scale, f) if c != aruco_cameras[0] else f
    return scale


def _choose_render_checked(F_base, cand, X, s_r, s_t, k, feasible, scale, refine, sysm,
                           render_check, aruco_cameras, kw) -> tuple:
    """The chain, chosen again without the stops the render check finds unmeasured (at most
    4 rounds; if the last still finds some, chosen among the stops the renders measured):
    ``(g, added, added_g, rejected, markers per chosen stop and camera)``."""
    def choose(feas):
        return pl.greedy_chain_systematic(
            F_base, cand.motion["cam_a"], X, s_r, s_t, k, feasible=feas,
            noise_scale=scale, refine=refine, systematic=sysm, **kw)
    rejected, seen, measured = [], {c: {} for c in aruco_cameras}, set()
    for _ in range(4):
        g, added, added_g = choose(feasible)
        if render_check is None or not aruco_cameras or g.order.size == 0:
            return g, added, added_g, rejected, {}
        bad, checked = _unmeasured_stops(render_check(cand, g.order), aruco_cameras, g.order)
        if not bad:
            return g, added, added_g, rejected, checked
        for c in aruco_cameras:
            seen[c].update(zip(g.order.tolist(), checked[c]))
        measured |= set(g.order.tolist()) - set(bad)
        rejected += sorted(set(bad))
        feasible[np.array(sorted(set(bad)))] = False
    only = np.zeros_like(feasible)
    only[sorted(measured)] = True
    g, added, added_g = choose(feasible & only)
    return g, added, added_g, rejected, {c: [seen[c][int(j)] for j in g.order]
                                         for c in aruco_cameras}


def _unmeasured_stops(streams, aruco_cameras, order) -> tuple[list, dict]:
    """``(bad, checked)``: stops an ArUco camera measured no pose at, its markers per stop."""
    bad = []
    checked = {}
    for c in aruco_cameras:
        got = set(int(f) for f in np.asarray(streams[c].frame_index))
        nm = np.asarray(streams[c].info.get("n_markers", np.zeros(0)))
        per = {int(f): int(nm[j]) if j < nm.size else -1
               for j, f in enumerate(np.asarray(streams[c].frame_index))}
        checked[c] = [per.get(j + 1, 0) for j in range(order.size)]
        bad += [int(order[j]) for j in range(order.size) if (j + 1) not in got]
        if 0 not in got:
            raise ValueError(f"{c} measures no pose at the reference stop; advice needs "
                             "the reference pose")
    return bad, checked


def _usable(cand, rejected) -> np.ndarray:
    """``(N,)`` feasible candidates the render check did not reject."""
    usable = cand.feasible.copy()
    usable[list(rejected)] = False
    return usable


def check_when_determined(when_determined) -> str:
    """``when_determined`` if it is one of :data:`WHEN_DETERMINED`, else ValueError."""
    if when_determined not in WHEN_DETERMINED:
        raise ValueError(f"when_determined must be one of {list(WHEN_DETERMINED)}; received "
                         f"{when_determined!r}")
    return when_determined


def recorded_information(C, H, X, alpha: float, *, tolerance_deg: float = 1.0,
                         tolerance_m: float = 0.01) -> tuple:
    """``(sigma_r_rad, sigma_t_m, F_base, L)``: the eq. 38 noise fitted to the recorded
    motions' residuals at ``X`` (:func:`~simcalib.solvers.diagnostics.uncertainty.covariance`),
    their summed Fisher information ``(6, 6)`` and the translation range ``L`` (m) beyond
    which a direction counts as undetermined."""
    from simcalib.solvers.diagnostics.uncertainty import covariance
    u = covariance(C, H, X, alpha, tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)
    s_r, s_t = u.noise.sigma_r_rad, u.noise.sigma_t_m
    return (s_r, s_t, pl.motion_information(C, H, X, s_r, s_t).sum(axis=0),
            u.translation_scale_m)


def determined_message(F_base, when_determined: str, **kw) -> tuple[str, bool]:
    """``(message, propose)``: when the recorded information ``F_base`` already determines
    every direction within the tolerance, say so; ``propose`` is False then only for
    ``when_determined="stop"``."""
    check_when_determined(when_determined)
    worst = pl.max_std_tolerance_units(F_base, **kw)
    if worst > 1.0:
        return "", True
    message = (f"X is already determined within the tolerance by the recorded motions "
               f"(largest predicted 1-sigma {worst:.3g} tolerance units); ")
    if when_determined == "stop":
        return message + ("no motion proposed (when_determined='advise' / force=true: the "
                          "k stops that lower it most)"), False
    return message + ("the stops below lower it further (when_determined='stop' / "
                      "force=false: propose none)"), True


def predicted_along_chain(F_base, added, added_g, sysm, L: float, **kw) -> tuple:
    """``(std_before (6,), std_after (k, 6))``: predicted 1-sigma per axis with the recorded
    information ``F_base`` and after each stop's information ``added`` (with ``sysm``, the
    systematic scores: ``sysm[0]`` the recorded one, ``added_g`` each stop's)."""
    def std(F, G):
        if sysm is None:
            return pl.predicted_std(F, range_m=L, **kw)
        return pl.systematic_std(F, G, range_m=L, **kw)

    F = np.asarray(F_base, dtype=np.float64).copy()
    G = sysm[0].copy() if sysm is not None else None
    after = []
    for j, Fa in enumerate(added):
        F = F + Fa
        G = G + added_g[j] if G is not None else None
        after.append(std(F, G))
    return std(F_base, None if sysm is None else sysm[0]), np.array(after).reshape(-1, 6)


#: random chains :func:`advise_motions` predicts, to compare the chosen chain with
N_RANDOM_CHAINS = 200


def random_chains(F_base, motion_a, X, s_r, s_t, usable, k: int, rng, *, noise_scale,
                  systematic, range_m: float, n: int = N_RANDOM_CHAINS, **kw) -> tuple:
    """``(chains (n, k), std (n, 6))``: ``n`` chains of ``k`` stops drawn uniformly (without
    replacement within a chain) from the ``usable`` candidates and the predicted 1-sigma per
    axis after each (deg, m; :func:`planner.chain_information`, the same model as the
    choice): what choosing is expected to gain over visiting as many of the same
    candidates without choosing. ``(None, None)`` when fewer than ``k`` are usable or
    ``k`` is 0."""
    idx = np.flatnonzero(usable)
    if k < 1 or idx.size < k:
        return None, None
    chains = np.stack([rng.choice(idx, size=k, replace=False) for _ in range(int(n))])
    F, G = pl.chain_information(F_base, motion_a, X, s_r, s_t, chains,
                                noise_scale=noise_scale, systematic=systematic)
    if systematic is None:
        std = [pl.predicted_std(f, range_m=range_m, **kw) for f in F]
    else:
        std = [pl.systematic_std(f, g, range_m=range_m, **kw) for f, g in zip(F, G)]
    return chains, np.array(std)


def expected_gain(adv) -> dict:
    """The planner's own expectation of what its choice gains (no simulation): the advised
    chain's largest predicted 1-sigma (deg, cm) against the median over
    :attr:`Advice.random_chains` (random stops from the same candidates); empty without
    them."""
    if adv.random_chains_std is None or len(adv.std_after) == 0:
        return {}
    a = np.asarray(adv.std_after[-1], dtype=np.float64)
    r = np.asarray(adv.random_chains_std, dtype=np.float64)
    adv_deg, adv_cm = float(a[:3].max()), 100.0 * float(a[3:].max())
    rnd_deg = float(np.median(r[:, :3].max(axis=1)))
    rnd_cm = 100.0 * float(np.median(r[:, 3:].max(axis=1)))

    def ratio(x, y):
        return x / y if np.isfinite(x) and np.isfinite(y) and y > 0 else None
    return {"chains": int(r.shape[0]), "stops": int(adv.random_chains.shape[1]),
            "advised_max_std_deg": _f(adv_deg), "advised_max_std_cm": _f(adv_cm),
            "random_max_std_deg_median": _f(rnd_deg), "random_max_std_cm_median": _f(rnd_cm),
            "expected_ratio_rotation": _f(ratio(adv_deg, rnd_deg)),
            "expected_ratio_translation": _f(ratio(adv_cm, rnd_cm))}


def lens_distortion(run_cfg) -> "np.ndarray | None":
    """The ArUco cameras' lens distortion (k1, k2, p1, p2, k3) of the run's vision
    configuration (what the render images through), None without a run configuration:
    the candidates' visibility and view quality are judged in the image the camera sees."""
    return None if run_cfg is None else np.asarray(run_cfg.vision.effects().distortion,
                                                   dtype=np.float64)


def _stop_bases(world, cfg, sources, T_world_cam, qpos, P) -> np.ndarray:
    """``(2, F, 6, P)``: :func:`simcalib.pipeline.uncertainty_inputs.stop_error_basis` of
    cameras a and b (``sources``: camera -> pose source) at the poses ``T_world_cam[camera]``
    (F, 4, 4)
    and joint states ``qpos`` (F, nq); zero where a camera's source has none."""
    from simcalib.pipeline.uncertainty_inputs import stop_error_basis
    qpos = np.asarray(qpos)
    out = np.zeros((2, qpos.shape[0], 6, P))
    for k, cam in enumerate(("cam_a", "cam_b")):
        B = stop_error_basis(world, cfg, cam, sources.get(cam), T_world_cam[cam], qpos=qpos)
        if B is not None:
            out[k] = B
    return out


def _systematic(world, cand, C, H, X, s_r, s_t, recorded, sources, cfg):
    """``((G_base, B_ref, B_cand), groups)``: for :func:`planner.greedy_chain` the recorded
    motions' summed systematic score and the error bases of the reference and candidate
    stops (:func:`simcalib.pipeline.uncertainty_inputs.stop_error_basis` of each camera's
    source), in the columns of the recorded basis, columns no pose uses dropped; ``groups`` the
    source of
    each kept column (:data:`UNCERTAINTY_SOURCES`)."""
    Ba, Bb, pairs = recorded
    Ba, Bb = np.asarray(Ba, dtype=np.float64), np.asarray(Bb, dtype=np.float64)
    T = {c: np.concatenate([cand.ref["T_world_cam"][c][None], cand.T_world_cam[c]])
         for c in ("cam_a", "cam_b")}
    q = np.concatenate([np.asarray(cand.ref["qpos"])[None], np.asarray(cand.qpos)])
    B = _stop_bases(world, cfg, sources, T, q, Ba.shape[2])
    B_ref, B_cand = B[:, 0], B[:, 1:]
    G_base = pl.systematic_scores(C, H, X, s_r, s_t, Ba[pairs[:, 0]], Ba[pairs[:, 1]],
                                  Bb[pairs[:, 0]], Bb[pairs[:, 1]]).sum(axis=0)
    used = (np.any(Ba != 0, axis=(0, 1)) | np.any(Bb != 0, axis=(0, 1))
            | np.any(B_ref != 0, axis=(0, 1)) | np.any(B_cand != 0, axis=(0, 1, 2)))
    return (G_base[:, used], B_ref[:, :, used], B_cand[:, :, :, used]), \
        [g for g, u in zip(_column_groups(world), used) if u]


#: each source of X's predicted uncertainty (:func:`limited_by`): name -> (its columns in
#: :func:`simcalib.pipeline.uncertainty_inputs.basis_layout`, None for the white noise; a short
#: name; what would lower its share)
UNCERTAINTY_SOURCES = {
    "white noise": (None, "the pose noise", "more stops, or several frames averaged at "
                    "each stop (stop_frames=), lower it"),
    "marker map": ("map", "the marker map's survey error", "it is shared by every stop: a "
                   "more accurate survey of the markers would lower it "
                   "(vision.map_position_std_m / map_rotation_std_deg describe the survey), "
                   "more stops barely"),
    "calibration of cam_a": ("cal_a", "cam_a's intrinsic calibration error", "it is shared "
                             "by every stop: recalibrating cam_a would lower it "
                             "(vision.intrinsics_error describes it), more stops barely"),
    "calibration of cam_b": ("cal_b", "cam_b's intrinsic calibration error", "it is shared "
                             "by every stop: recalibrating cam_b would lower it "
                             "(vision.intrinsics_error describes it), more stops barely"),
    "DH table of the arm": ("dh", "the arm's kinematic (DH table) error", "it is shared by "
                            "every stop: a kinematic calibration of the arm would lower it "
                            "(robot.kinematic_error describes it), more stops barely"),
}


def cannot_help_axes(cannot_help) -> list:
    """The axes (:data:`AXES`) the directions of :func:`planner.undeterminable` move (a
    component above 0.3 of the rotation axis or translation direction)."""
    out = set()
    for h in cannot_help:
        for block, key in ((0, "rotation_axis_a"), (3, "translation_dir_a")):
            v = np.abs(np.asarray(h.get(key, np.zeros(3)), dtype=np.float64))
            out.update(AXES[block + i] for i in np.flatnonzero(v > 0.3))
    return [a for a in AXES if a in out]


def _column_groups(world) -> list:
    """The source name (:data:`UNCERTAINTY_SOURCES`) of each column of
    :func:`simcalib.pipeline.uncertainty_inputs.basis_layout`."""
    from simcalib.pipeline.uncertainty_inputs import basis_layout
    lay = basis_layout(world)
    out = [""] * lay["P"]
    for name, (key, _, _) in UNCERTAINTY_SOURCES.items():
        if key is not None:
            out[lay[key]] = [name] * (lay[key].stop - lay[key].start)
    return out


def limited_by(F, G, groups, std, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
               range_m: float = 1.0, exclude=()) -> dict:
    """What X's predicted uncertainty is made of (:func:`planner.variance_shares`) with the
    information ``F``, the systematic score ``G`` (6, P) and its column ``groups``, and
    ``std`` (6,) the 1-sigma per axis: ``per_axis`` (axis -> source -> share of the
    variance), ``axis`` (the largest 1-sigma in tolerance units), its ``std`` and
    ``shares``, the ``dominant`` source and a ``statement`` saying what would lower it.
    ``exclude``: axes no motion of the platform determines (:func:`cannot_help_axes`),
    left to the ``cannot_help`` statements. Empty when no other axis is determined."""
    std = np.asarray(std, dtype=np.float64)
    tol = np.array([tolerance_deg] * 3 + [tolerance_m] * 3)
    in_tol = np.where(np.isfinite(std) & ~np.isin(AXES, list(exclude)), std / tol, -np.inf)
    if not np.isfinite(in_tol).any():
        return {}
    shares, names = pl.variance_shares(F, G, groups, tolerance_deg=tolerance_deg,
                                       tolerance_m=tolerance_m, range_m=range_m)
    per_axis = {a: {n: _f(v) for n, v in zip(names, row)} for a, row in zip(AXES, shares)}
    w = int(np.argmax(in_tol))
    row = {n: float(v) for n, v in zip(names, shares[w]) if np.isfinite(v)}
    if not row:
        return {}
    order = sorted(row, key=row.get, reverse=True)
    top = order[0]
    unit = f"{std[w]:.3g} deg" if w < 3 else f"{100 * std[w]:.3g} cm"
    def short(n):
        return UNCERTAINTY_SOURCES.get(n, (None, n, ""))[1]
    parts = ", ".join(f"{100 * row[n]:.0f} % {short(n)}" for n in order if row[n] >= 0.05)
    but = (f" (apart from {', '.join(exclude)}, which no motion of this platform "
           f"determines: see cannot_help)" if len(exclude) else "")
    statement = (f"the largest predicted 1-sigma{but} ({AXES[w]}: {unit}) comes from "
                 f"{parts}; the largest share, {short(top)}: "
                 f"{UNCERTAINTY_SOURCES.get(top, (None, '', 'n/a'))[2]}")
    return {"axis": AXES[w], "std": float(std[w]), "shares": row, "dominant": top,
            "statement": statement, "per_axis": per_axis}


def advise(base: Baseline, k: int = 5, *, seed: int = 0, n_candidates: int = N_CANDIDATES,
           tolerance_deg: float = 1.0, tolerance_m: float = 0.01, render: bool = True,
           when_determined: str = "advise", systematic: bool = True, **cand_kw) -> Advice:
    """Advice for a :class:`Baseline` (candidates drawn from ``seed``); ``systematic``: weigh
    the recorded run's systematic pose errors (``base.pose_error_basis``) in the choice."""
    rng = np.random.default_rng([int(seed), 13])
    rc_rng = np.random.default_rng([int(seed), 17])

    def check(cand, idx):
        return fz.execute_stops(base.truth, base.cfg, cand, idx, rc_rng)

    return advise_motions(base.truth.world, base.C, base.H, base.X, k, rng=rng,
                          alpha=base.alpha, n_candidates=n_candidates,
                          aruco_cameras=base.aruco_cameras, tolerance_deg=tolerance_deg,
                          tolerance_m=tolerance_m, render_check=check if render else None,
                          when_determined=when_determined,
                          pose_error_basis=base.pose_error_basis if systematic else None,
                          run_cfg=base.cfg, sources=base.sources, **cand_kw)


def _systematic_inputs(base: Baseline, cand, idx, streams, got) -> dict:
    """``pose_pairs`` / ``pose_error_basis`` of the recorded motions followed by the chain of
    measured stops (datapoint ``D`` the reference, ``D + j + 1`` the ``j``-th measured
    stop; :func:`feasibility.stop_motions` chains the measured ones), so that the
    verification's covariance includes the systematic pose errors as a run's does; ``{}``
    without a recorded basis."""
    if base.pose_error_basis is None or not np.asarray(got).size:
        return {}
    Ba, Bb, pairs = base.pose_error_basis
    D = Ba.shape[0]
    got = np.asarray(got, dtype=np.int64)
    frames = np.concatenate([[0], got])
    T = {}
    for cam in ("cam_a", "cam_b"):
        st = streams[cam]
        pos = {int(f): k for k, f in enumerate(np.asarray(st.frame_index))}
        T[cam] = np.asarray(st.T_world_cam)[[pos[int(f)] for f in frames]]
    stops = _stop_bases(base.truth.world, base.cfg, base.sources, T,
                        fz.stop_state(cand, idx)[0][frames], Ba.shape[2])
    row = np.arange(1, got.size + 1)              # stop got[j] is row j + 1 (0: reference)
    chain = np.stack([D + row - 1, D + row], axis=1)
    return {"pose_pairs": np.concatenate([pairs, chain]),
            "pose_error_basis": (np.concatenate([Ba, stops[0]]),
                                 np.concatenate([Bb, stops[1]]))}


def solve_errors(C, H, X_true, alpha, *, tolerance_deg=1.0, tolerance_m=0.01,
                 pose_pairs=None, pose_error_basis=None) -> dict:
    """dqopt on ``C``, ``H``: actual errors against ``X_true`` and the predicted 1-sigma
    (with ``pose_pairs`` / ``pose_error_basis``: the systematic pose errors included, as in
    a run)."""
    from simcalib.solvers.api import solve
    sol = solve(C, H, method="dqopt", alpha=alpha, tolerance_deg=tolerance_deg,
                         tolerance_m=tolerance_m, pose_pairs=pose_pairs,
                         pose_error_basis=pose_error_basis)
    X = np.asarray(sol.X, dtype=np.float64)
    if not sol.success or not np.isfinite(X).all():
        return {"success": False, "error": sol.solver_message, "n_motions": int(C.shape[0])}
    rot_deg, trans_cm = _errors_against(X, X_true)
    try:
        std = np.asarray(sol.std, dtype=np.float64)
        verdict = sol.verdict
    except Exception as exc:  # noqa: BLE001 - report, never pretend
        std, verdict = np.full(6, np.nan), f"unavailable: {exc}"
    return {"success": True, "n_motions": int(C.shape[0]),
            "rotation_error_deg": rot_deg, "translation_error_cm": trans_cm,
            "predicted_std": _std_dict(std), "verdict": verdict,
            "max_std_deg": _f(np.max(std[:3])), "max_std_cm": _f(100 * np.max(std[3:]))}


def _errors_against(X, X_true) -> tuple[float, float]:
    """``(rotation error deg, translation error cm)`` of the estimate ``X``."""
    from simcalib.geometry import rotation_error_rad
    return (float(np.rad2deg(rotation_error_rad(X, X_true))),
            float(100 * np.linalg.norm(X[:3, 3] - X_true[:3, 3])))


def _std_dict(s) -> dict:
    return {a: (None if not np.isfinite(v) else float(v)) for a, v in zip(AXES, s)}


@dataclass(frozen=True)
class Verification:
    """Actual errors and predicted 1-sigma of dqopt for ``baseline``, ``advised`` and each
    ``random`` seed (dicts of :func:`solve_errors` plus ``stops_measured``), the medians
    over the random seeds and the ratios **median over seeds of the advised stops** (each
    seed's measurement noise, ``advised_seeds``, ``advised_median``) / median random
    (``advised`` is the advised stops measured once, with the scenario's seed). ``random_joint*`` /
    ``ratio_joint``: the same for the joint-jog baseline (arm only: k stops drawn from
    :func:`feasibility.joint_candidates`); ``random_wide*`` / ``ratio_wide``: k stops
    drawn at random from the planner's own feasible candidates (its wider ranges: how much
    of the gain is moving farther rather than choosing); ``motion_size``: median rotation
    (deg) and translation (cm) of camera a's stop-to-stop motions for ``advised``,
    ``random``, ``random_joint``, ``random_wide``; ``frames_per_stop``: frames averaged
    at each stop; ``hindsight`` / ``ratio_hindsight`` (with ``hindsight=True``): the
    :func:`hindsight_stops` bound (k stops picked with the true X) and its ratio to the
    random median."""
    baseline: dict
    advised: dict
    random: list
    random_median: dict
    ratio: dict
    timing_s: dict
    random_joint: list = field(default_factory=list)
    random_joint_median: dict = field(default_factory=dict)
    ratio_joint: dict = field(default_factory=dict)
    motion_size: dict = field(default_factory=dict)
    advised_seeds: list = field(default_factory=list)
    advised_median: dict = field(default_factory=dict)
    random_wide: list = field(default_factory=list)
    random_wide_median: dict = field(default_factory=dict)
    ratio_wide: dict = field(default_factory=dict)
    frames_per_stop: int = 1
    hindsight: dict = field(default_factory=dict)
    ratio_hindsight: dict = field(default_factory=dict)


#: random starts of :func:`choice_floor`'s search (besides the planner's chain)
N_FLOOR_STARTS = 6


def choice_floor(base: Baseline, adv: Advice, *, n_starts: int = N_FLOOR_STARTS,
                 n_random: int = 300, n_chains: int = N_RANDOM_CHAINS) -> dict:
    """How much any choice of stops can gain, by the planner's own model (no simulation):
    the expected error of X (root-mean-square norm of its rotation, deg, and of its
    translation, cm: white noise and the shared pose errors) after the advised stops;
    the smallest a chain of ``adv.k`` of the advice's usable candidates reaches, as far as
    :func:`planner.best_expected_chains` finds (rotation and translation each searched on
    its own, from the planner's chain and ``n_starts`` random chains); and the median over
    ``n_chains`` chains of ``adv.k`` random stops of the verification's random baseline
    (:func:`random_baseline_candidates`, ``n_random`` drawn). A *floor* ratio above a
    target says that no choice among these candidates the search finds can be expected
    to reach it on a rig of this kind: only knowing this rig's shared errors (the
    hindsight bound of :func:`hindsight_stops`) could. A block (rotation, translation)
    along which no feasible candidate determines X (``adv.cannot_help``) gets None. Empty when the advice proposes
    fewer than ``k`` stops."""
    k = int(adv.chosen.size)
    if k < 1 or k != adv.k:
        return {}
    world = base.truth.world
    s_r, s_t = adv.noise
    kw = dict(tolerance_deg=adv.tolerance_deg, tolerance_m=adv.tolerance_m)
    lens = lens_distortion(base.cfg)
    rng = np.random.default_rng([int(base.cfg.seed), 707])

    def model(cand):
        sysm = None if base.pose_error_basis is None else _systematic(
            world, cand, base.C, base.H, adv.X, s_r, s_t, base.pose_error_basis,
            base.sources, base.cfg)[0]
        return sysm, _view_noise_scale(world, cand, base.aruco_cameras, lens, True)

    cand = adv.candidates
    sysm, scale = model(cand)
    usable = _usable(cand, adv.rejected_by_render)
    idx = np.flatnonzero(usable)
    starts = np.concatenate([adv.chosen[None]] + [rng.choice(idx, k, replace=False)[None]
                                                  for _ in range(int(n_starts))])
    best = pl.best_expected_chains(adv.F_base, cand.motion["cam_a"], adv.X, s_r, s_t, starts,
                                   feasible=usable, noise_scale=scale, systematic=sysm, **kw)
    F, G = pl.chain_information(adv.F_base, cand.motion["cam_a"], adv.X, s_r, s_t,
                                adv.chosen[None], noise_scale=scale, systematic=sysm)
    advised = pl.expected_errors(F, G, **kw)[0]
    rc = random_baseline_candidates(base, n_random)
    sysm_r, scale_r = model(rc)
    feas = np.flatnonzero(rc.feasible)
    if feas.size < k:
        return {}
    chains = np.stack([rng.choice(feas, k, replace=False) for _ in range(int(n_chains))])
    F, G = pl.chain_information(adv.F_base, rc.motion["cam_a"], adv.X, s_r, s_t, chains,
                                noise_scale=scale_r, systematic=sysm_r)
    rand = np.median(pl.expected_errors(F, G, **kw), axis=0)
    out = {"stops": k, "starts": int(starts.shape[0]), "random_chains": int(chains.shape[0])}
    # a block with a direction no feasible candidate determines (cannot_help: the planar
    # cart's vertical translation) has no floor to speak of: None
    cannot = cannot_help_axes(adv.cannot_help)
    for b, (name, unit, to_unit) in enumerate((("rotation", "deg", 1.0),
                                               ("translation", "cm", 100.0))):
        res = best[name]
        floor = res["expected_deg" if b == 0 else "expected_m"]
        per = res["per_start_deg" if b == 0 else "per_start_m"]
        det = not set(cannot) & set(AXES[3 * b:3 * b + 3])
        out.update({
            f"advised_expected_{unit}": _det(to_unit * advised[b], det),
            f"floor_expected_{unit}": _det(to_unit * floor, det),
            f"random_expected_{unit}": _det(to_unit * rand[b], det),
            f"ratio_advised_{name}": _det(advised[b] / rand[b], det),
            f"ratio_floor_{name}": _det(floor / rand[b], det),
            f"floor_per_start_{unit}": [to_unit * float(v) for v in per]})
    out["floor_chains"] = {"rotation": best["rotation"]["chain"],
                           "translation": best["translation"]["chain"]}
    return out


def _det(value, determined: bool):
    """``float(value)`` where the block is determined, else None."""
    return float(value) if determined else None


def random_baseline_candidates(base: Baseline, n: int = 300) -> fz.Candidates:
    """The random baseline's own feasible set: ``n`` stops drawn with the ``"jog"`` ranges
    (arm 5-40 deg, 15 cm; cart +-90 deg, 1 m) whatever ranges the planner was given, from
    the scenario's seed (the same set for every verification of a run)."""
    return fz.candidates(base.truth.world, n, np.random.default_rng([int(base.cfg.seed), 13]),
                         aruco_cameras=base.aruco_cameras, ranges="jog",
                         distortion=lens_distortion(base.cfg))


def verify(base: Baseline, adv: Advice, *, seeds=(0, 1, 2, 3, 4), joint_baseline: bool = True,
           max_joint_deg: float = 20.0, n_joint: int = 300, n_random: int = 300,
           wide_baseline: bool = True, frames_per_stop: int = 1,
           hindsight: bool = False) -> Verification:
    """Execute the advised stops and ``len(seeds)`` sets of ``k`` random feasible stops
    in the simulator; solve with each added. Random baselines: ``random``, uniform over
    ``n_random`` feasible stops drawn by :func:`feasibility.candidates` with the ``"jog"``
    ranges (arm: flange rotated 5-40 deg about a uniform axis, moved up to 15 cm; cart:
    yaw +-90 deg, 1 m; never screened by information); for the arm with
    ``joint_baseline``, ``random_joint``: ``k`` feasible stops of ``n_joint`` joint jogs of
    +-``max_joint_deg`` per joint around the reference
    (:func:`feasibility.joint_candidates`); with ``wide_baseline``, ``random_wide``: ``k``
    stops uniform over the planner's own feasible candidates. ``frames_per_stop``: frames
    recorded and averaged at each stop, for every set of stops alike
    (:func:`feasibility.execute_stops`). ``hindsight``: also the bound of
    :func:`hindsight_stops` on the planner's candidates (measured with the first seed's
    noise, scored against the random medians)."""
    t0 = time.perf_counter()
    X_true = base.truth.X_true
    kw = dict(tolerance_deg=adv.tolerance_deg, tolerance_m=adv.tolerance_m)
    rec = {} if base.pose_error_basis is None else {
        "pose_pairs": base.pose_error_basis[2], "pose_error_basis": base.pose_error_basis[:2]}
    res0 = solve_errors(base.C, base.H, X_true, base.alpha, **kw, **rec)

    def run(idx, rng, cand=adv.candidates):
        streams = fz.execute_stops(base.truth, base.cfg, cand, idx, rng,
                                   frames_per_stop=frames_per_stop)
        Cs, Hs, got = fz.stop_motions(streams, chain=True)
        r = solve_errors(np.concatenate([base.C, Cs]), np.concatenate([base.H, Hs]), X_true,
                         base.alpha, **kw,
                         **_systematic_inputs(base, cand, idx, streams, got))
        r["stops_measured"] = int(got.size)
        r["stops"] = [int(i) for i in idx]
        r["motion_size"] = _motion_size(cand, idx)
        return r

    if adv.chosen.size:
        res_adv = run(adv.chosen, np.random.default_rng([base.cfg.seed, 101]))
        # the same advised stops measured with each seed's measurement noise (the random
        # draws of seed s use the same measurement stream: common random numbers)
        res_adv_seeds = []
        for s in seeds:
            r = run(adv.chosen, np.random.default_rng([int(s), 303]))
            r["seed"] = int(s)
            res_adv_seeds.append(r)
    else:                                   # advice: no motion needed
        res_adv = dict(res0, stops_measured=0, stops=[])
        res_adv_seeds = [dict(res0, stops_measured=0, stops=[], seed=int(s)) for s in seeds]
    adv_med, _ = _summary({}, res_adv_seeds)
    rc = random_baseline_candidates(base, n_random)
    def random_runs(cands, salt: int) -> list[dict]:
        """k random feasible stops of ``cands`` per seed (choice drawn with ``salt``)."""
        feas = np.flatnonzero(cands.feasible)
        out = []
        for s in seeds if feas.size else ():
            rng = np.random.default_rng([int(s), salt])
            idx = rng.choice(feas, size=min(adv.k, feas.size), replace=False)
            r = run(idx, np.random.default_rng([int(s), 303]), cands)
            r["seed"] = int(s)
            out.append(r)
        return out

    res_rand = random_runs(rc, 202)
    med, ratio = _summary(adv_med, res_rand)
    res_joint, med_j, ratio_j = [], {}, {}
    if joint_baseline and adv.candidates.platform == "arm" and adv.k > 0:
        jc = fz.joint_candidates(base.truth.world, n_joint,
                                 np.random.default_rng([int(base.cfg.seed), 404]),
                                 aruco_cameras=base.aruco_cameras, max_joint_deg=max_joint_deg,
                                 distortion=lens_distortion(base.cfg))
        res_joint = random_runs(jc, 505)
        med_j, ratio_j = _summary(adv_med, res_joint)
    res_wide, med_w, ratio_w = [], {}, {}
    if wide_baseline and adv.k > 0:
        res_wide = random_runs(adv.candidates, 606)
        med_w, ratio_w = _summary(adv_med, res_wide)
    hind, ratio_h = {}, {}
    if hindsight and adv.k > 0 and med.get("rotation_error_deg") and \
            med.get("translation_error_cm"):
        hind = hindsight_stops(base, adv.candidates, adv.k,
                               np.random.default_rng([int(seeds[0]), 303]),
                               scale=(med["rotation_error_deg"], med["translation_error_cm"]),
                               chains=adv.random_chains, chains_std=adv.random_chains_std)
        _, ratio_h = _summary(hind, res_rand)
    size = {"advised": res_adv.get("motion_size"),
            "random": _median_size([r.get("motion_size") for r in res_rand]),
            "random_joint": _median_size([r.get("motion_size") for r in res_joint]),
            "random_wide": _median_size([r.get("motion_size") for r in res_wide])}
    return Verification(res0, res_adv, res_rand, med, ratio,
                        {"verification": time.perf_counter() - t0}, res_joint, med_j,
                        ratio_j, size, res_adv_seeds, adv_med, res_wide, med_w, ratio_w,
                        frames_per_stop=int(frames_per_stop), hindsight=hind,
                        ratio_hindsight=ratio_h)


def hindsight_stops(base: Baseline, cand, k: int, rng: np.random.Generator, *,
                    scale=(1.0, 1.0), chains=None, chains_std=None) -> dict:
    """The ``k`` stops of ``cand`` a chooser that knew the true X would visit: **not
    advice** (no planner has the truth) but what these candidates can give on this rig
    (greedy, so the best choice of ``k`` of them does at least as well: an upper bound on
    the smallest reachable error). Every feasible candidate is measured once (the rig of
    the recorded run, per-frame noise from ``rng``), then stops are added greedily (stop
    and go, from the reference), each the one whose chain gives dqopt the smallest
    ``max(rotation error / scale[0] deg, translation error / scale[1] cm)`` against the
    true X. Returns ``stops`` (candidate indices, in order), ``rotation_error_deg``,
    ``translation_error_cm``, ``success``, ``measured`` (candidates measured); with
    ``chains`` ``(n, k)`` and their predicted 1-sigma ``chains_std`` ``(n, 6)``
    (:attr:`Advice.random_chains`) also ``ranking`` (:func:`ranking_agreement`): how well
    the planner's prediction ranks those chains by their actual errors."""
    from simcalib.solvers.api import solve
    from simcalib.geometry import invert_transform
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an integer >= 1; received {k!r}")
    s_deg, s_cm = (float(x) for x in scale)
    if not (s_deg > 0 and s_cm > 0 and np.isfinite(s_deg) and np.isfinite(s_cm)):
        raise ValueError(f"scale must be two positive numbers (deg, cm); received {scale!r}")
    feas = np.flatnonzero(cand.feasible)
    streams = fz.execute_stops(base.truth, base.cfg, cand, feas, rng)
    pose = {}
    for cam in ("cam_a", "cam_b"):
        st = streams[cam]
        pose[cam] = {int(f): T for f, T in zip(np.asarray(st.frame_index),
                                               np.asarray(st.T_world_cam))}
    ok = [f for f in pose["cam_a"] if f in pose["cam_b"]]
    if 0 not in ok:
        return {"success": False, "stops": [], "measured": 0}
    X_true = base.truth.X_true

    def errors(frames):
        prev = [0] + frames[:-1]
        C = [invert_transform(pose["cam_a"][p]) @ pose["cam_a"][f] for p, f in zip(prev, frames)]
        H = [invert_transform(pose["cam_b"][p]) @ pose["cam_b"][f] for p, f in zip(prev, frames)]
        sol = solve(np.concatenate([base.C, C]), np.concatenate([base.H, H]),
                             method="dqopt", alpha=base.alpha)
        X = np.asarray(sol.X, dtype=np.float64)
        if not sol.success or not np.isfinite(X).all():
            return np.inf, np.inf
        return _errors_against(X, X_true)

    chosen, best = [], (np.inf, np.inf)
    for _ in range(int(k)):
        step = None                               # (score, frame, errors) of the best stop
        for f in ok:
            if f == 0 or f in chosen:
                continue
            e = errors(chosen + [f])
            score = max(e[0] / s_deg, e[1] / s_cm)
            if step is None or score < step[0]:
                step = (score, f, e)
        if step is None:
            break
        chosen.append(step[1])
        best = step[2]
    out = {"success": bool(np.isfinite(best).all()),
           "stops": [int(feas[f - 1]) for f in chosen],
           "rotation_error_deg": _f(best[0]), "translation_error_cm": _f(best[1]),
           "measured": int(len(ok) - 1)}
    if chains is not None and chains_std is not None:
        frame = {int(c): j + 1 for j, c in enumerate(feas)}
        keep, actual = [], []
        for i, ch in enumerate(np.asarray(chains)):
            fr = [frame.get(int(c), -1) for c in ch]
            if all(f in pose["cam_a"] and f in pose["cam_b"] for f in fr):
                keep.append(i)
                actual.append(errors(fr))
        out["ranking"] = ranking_agreement(np.asarray(chains_std)[keep],
                                           np.array(actual).reshape(-1, 2))
    return out


def ranking_agreement(predicted_std, actual) -> dict:
    """How well predicted 1-sigma ``(n, 6)`` (deg, m per axis) rank ``n`` chains by their
    actual errors ``(n, 2)`` (rotation deg, translation cm): per block, Spearman's rank
    correlation of the predicted error size (root sum of the axes' variances: the expected
    norm) with the actual error, and the median actual error of the tenth best-predicted
    chains over that of all (1: the prediction picks no better than chance). ``None``
    where a block is undetermined for some chain or fewer than 10 chains were measured."""
    from scipy.stats import spearmanr
    P = np.asarray(predicted_std, dtype=np.float64)
    A = np.asarray(actual, dtype=np.float64)
    out = {"chains": int(A.shape[0])}
    for b, name in ((0, "rotation"), (1, "translation")):
        pred = np.sqrt(np.sum(P[:, 3 * b:3 * b + 3] ** 2, axis=1))
        act = A[:, b]
        if A.shape[0] < 10 or not (np.isfinite(pred).all() and np.isfinite(act).all()):
            out[f"spearman_{name}"] = out[f"best_tenth_over_all_{name}"] = None
            continue
        best = pred <= np.quantile(pred, 0.1)
        out[f"spearman_{name}"] = _f(spearmanr(pred, act).statistic)
        out[f"best_tenth_over_all_{name}"] = _f(np.median(act[best]) / np.median(act))
    return out


def _summary(res_adv, res_rand):
    med = {}
    for key in ("rotation_error_deg", "translation_error_cm", "max_std_deg", "max_std_cm"):
        vals = [np.inf if r.get(key) is None else r[key] for r in res_rand
                if r.get("success")]
        med[key] = _f(np.median(vals)) if vals else None
    ratio = {}
    for key in ("rotation_error_deg", "translation_error_cm"):
        a, m = res_adv.get(key), med.get(key)
        ratio[key] = None if a is None or not m else float(a / m)
    return med, ratio


def _motion_size(cand, idx) -> dict:
    """Median rotation (deg) and translation (cm) of camera a's stop-to-stop motions."""
    from simcalib.geometry import invert_transform, rotvec_from_matrix
    idx = np.asarray(idx, dtype=np.int64)
    if idx.size == 0:
        return {"rotation_deg": None, "translation_cm": None}
    T = np.concatenate([np.eye(4)[None], cand.motion["cam_a"][idx]])
    D = invert_transform(T[:-1]) @ T[1:]
    ang = np.degrees(np.linalg.norm(rotvec_from_matrix(D[:, :3, :3]), axis=1))
    return {"rotation_deg": float(np.median(ang)),
            "translation_cm": float(100 * np.median(np.linalg.norm(D[:, :3, 3], axis=1)))}


def _median_size(sizes) -> dict:
    sizes = [s for s in sizes if s and s.get("rotation_deg") is not None]
    if not sizes:
        return {"rotation_deg": None, "translation_cm": None}
    return {k: float(np.median([s[k] for s in sizes]))
            for k in ("rotation_deg", "translation_cm")}


# ---------------------------------------------------------------------------- report
def _rel(T) -> dict:
    from simcalib.geometry import rotvec_from_matrix
    rv = rotvec_from_matrix(T[:3, :3])
    return {"rotvec_deg": np.degrees(rv).tolist(),
            "angle_deg": float(np.degrees(np.linalg.norm(rv))),
            "translation_m": T[:3, 3].tolist()}


def _prev_inv(cand, c, chosen, step):
    """Inverse of camera c's motion from the reference to the previous stop (stop and go:
    each advised motion starts at the previous stop, the first at the reference)."""
    from simcalib.geometry import invert_transform
    return np.eye(4) if step == 0 else invert_transform(cand.motion[c][int(chosen[step - 1])])


def _joint_names(model) -> list:
    import mujoco
    names = [""] * model.nq
    for j in range(model.njnt):
        a = int(model.jnt_qposadr[j])
        if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                      int(mujoco.mjtJoint.mjJNT_SLIDE)):
            names[a] = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"q{a}"
    return names


def advice_dict(base: Baseline, adv: Advice, ver: Verification | None = None,
                floor: dict | None = None) -> dict:
    """advice.json (see docs/advice.md); ``floor``: :func:`choice_floor`'s result, if any."""
    cand = adv.candidates
    world = base.truth.world
    names = _joint_names(world.model) if cand.platform == "arm" else []
    motions = []
    for step, j in enumerate(adv.chosen):
        m = {"step": step + 1, "candidate": int(j),
             "waypoint": {"T_world_target": cand.T_world_target[j].tolist(),
                          "dp_world_m": cand.dp_world_m[j].tolist(),
                          "rotvec_world_deg": np.degrees(cand.rotvec_world_rad[j]).tolist()},
             "camera_motions": {c: _rel(_prev_inv(cand, c, adv.chosen, step)
                                     @ cand.motion[c][j]) for c in cand.motion},
             "predicted_std_after": _std_dict(adv.std_after[step]),
             "max_std_tolerance_units_after": _f(adv.max_std_tol[step + 1])}
        if cand.platform == "arm":
            m["joint_targets_rad"] = {n: float(cand.qpos[j, a]) for a, n in enumerate(names)
                                      if n}
            m["ik_error"] = {"position_m": float(cand.ik_pos_error_m[j]),
                             "rotation_rad": float(cand.ik_rot_error_rad[j])}
        else:
            m["cart_pose"] = {"position_m": cand.mocap_pos[j, 0].tolist(),
                              "yaw_deg": float(np.degrees(cand.rotvec_world_rad[j, 2]))}
        m["visible_markers"] = {c: int(v[j]) for c, v in cand.visible.items()}
        m["rendered_markers"] = {c: v[step] for c, v in adv.render_check.items()
                                 if step < len(v)}
        motions.append(m)
    reasons: dict = {}
    for r in cand.reason:
        key = r.split(" (")[0] if r else "feasible"
        key = "cam sees too few markers" if "markers" in key else key
        reasons[key] = reasons.get(key, 0) + 1
    out = {"scenario": base.cfg.scenario, "platform": cand.platform,
           "path": base.cfg.world.path, "seed": base.cfg.seed, "k": adv.k,
           "criterion": ("greedy along the stop-and-go chain, then exchange passes: "
                         "minimise max + mean eigenvalue of the covariance in tolerance "
                         "units, (F + 1e-6 I)^-1 + (F + 1e-6 I)^-1 G G^T (F + 1e-6 I)^-1 "
                         "with the systematic pose errors' score G (marker map, "
                         "calibrations, the arm's DH table)" if adv.systematic_parameters
                         else
                         "greedy along the stop-and-go chain, then exchange passes: "
                         "minimise max + mean of 1/(lambda + 1e-6) of the information in "
                         "tolerance units (lambda_min = 1/largest sigma^2)"),
           "systematic_parameters": int(adv.systematic_parameters),
           "limited_by": adv.limited_by,
           "expected_gain": expected_gain(adv),
           "tolerance": {"deg": adv.tolerance_deg, "m": adv.tolerance_m},
           "noise_fitted": {"sigma_r_deg": math.degrees(adv.noise[0]),
                            "sigma_t_m": adv.noise[1]},
           "recorded_motions": int(base.C.shape[0]),
           "reference": {"frame": int(cand.ref["frame"]),
                         "T_world_target": cand.ref["T_world_target"].tolist(),
                         **({"joints_rad": {n: float(cand.ref["qpos"][a])
                                            for a, n in enumerate(names) if n}}
                            if names else {})},
           "predicted_std_before": _std_dict(adv.std_before),
           "max_std_tolerance_units_before": _f(adv.max_std_tol[0]),
           "message": adv.message,
           "motions": motions,
           "cannot_help": adv.cannot_help,
           "candidates": {"drawn": cand.n, "feasible": int(cand.feasible.sum()),
                          "by_reason": reasons,
                          "rejected_by_render_check": list(adv.rejected_by_render)},
           "timing_s": dict(adv.timing_s)}
    if floor:
        out["choice_floor"] = floor
    if ver is not None:
        out["verification"] = {"baseline": ver.baseline, "advised": ver.advised,
                               "random": ver.random, "random_median": ver.random_median,
                               "ratio_advised_to_random_median": ver.ratio,
                               "random_joint": ver.random_joint,
                               "random_joint_median": ver.random_joint_median,
                               "ratio_advised_to_random_joint_median": ver.ratio_joint,
                               "motion_size": ver.motion_size,
                               "advised_seeds": ver.advised_seeds,
                               "advised_median": ver.advised_median,
                               "random_wide": ver.random_wide,
                               "random_wide_median": ver.random_wide_median,
                               "ratio_advised_to_random_wide_median": ver.ratio_wide,
                               "frames_per_stop": ver.frames_per_stop,
                               "timing_s": ver.timing_s}
        if ver.hindsight:
            out["verification"]["hindsight"] = ver.hindsight
            out["verification"]["ratio_hindsight_to_random_median"] = ver.ratio_hindsight
    return out


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)
