"""Advice for a scenario's run: the recorded run (:func:`baseline`) and the next ``k`` stops
(:func:`advise`; :func:`advise_motions` is the core for motions from any source given a
world that models the platform). The candidates come from
:mod:`simcalib.studies.advise.feasibility`, the choice from
:mod:`simcalib.studies.advise.planner`; the proposed stops are measured in simulation by
:mod:`simcalib.studies.advise.verification`, bounded by
:mod:`simcalib.studies.advise.bounds` and written as advice.json by
:mod:`simcalib.studies.advise.advice_json`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

import simcalib.studies.advise.feasibility as fz
import simcalib.studies.advise.information as info
import simcalib.studies.advise.planner as pl
from simcalib.studies.advise.stops import execute_stops
from simcalib.studies.advise.systematic import cannot_help_axes, limited_by, systematic_model

__all__ = ["Baseline", "StopPlan", "Advice", "baseline", "advise", "advise_motions",
           "recorded_information", "determined_message", "predicted_along_chain",
           "check_when_determined", "check_advisable", "random_chains", "expected_gain",
           "view_noise_scale", "usable", "random_baseline_candidates", "PLATFORMS",
           "N_CANDIDATES", "N_RANDOM_CHAINS"]


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
    #: (:func:`simcalib.pipeline.uncertainty_inputs.pose_error_basis`, full layout) and the motions' datapoint
    #: pairs; None without such errors (ArUco: map / calibration; robot_fk: DH table)
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
    no feasible motion determines (with the fix), ``undetermined`` the same directions
    ``(6, r)`` in tolerance units (None: none; the predicted 1-sigma and the choice work on
    the others, :mod:`simcalib.studies.advise.information`); ``X``: the estimate it
    linearises at."""
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
    undetermined: np.ndarray | None = None


@dataclass(frozen=True)
class Advice(StopPlan):
    """A :class:`StopPlan` for a simulated platform: ``candidates`` (all drawn, with
    feasibility), ``render_check``: camera -> markers detected per chosen stop;
    ``rejected_by_render``: candidates dropped by it; ``F_base``, ``F_cand``: the recorded
    and the candidates' information."""
    candidates: fz.Candidates | None = None
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
#: random chains :func:`advise_motions` predicts, to compare the chosen chain with
N_RANDOM_CHAINS = 200


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
    return (s_r, s_t, info.motion_information(C, H, X, s_r, s_t).sum(axis=0),
            u.translation_scale_m)


def determined_message(F_base, when_determined: str, **kw) -> tuple[str, bool]:
    """``(message, propose)``: when the recorded information ``F_base`` already determines
    every direction within the tolerance, say so; ``propose`` is False then only for
    ``when_determined="stop"``."""
    check_when_determined(when_determined)
    worst = info.max_std_tolerance_units(F_base, **kw)
    if worst > 1.0:
        return "", True
    message = (f"X is already determined within the tolerance by the recorded motions "
               f"(largest predicted 1-sigma {worst:.3g} tolerance units); ")
    if when_determined == "stop":
        return message + ("no motion proposed (when_determined='advise' / force=true: the "
                          "k stops that lower it most)"), False
    return message + ("the stops below lower it further (when_determined='stop' / "
                      "force=false: propose none)"), True


def predicted_along_chain(F_base, added, added_g, sysm, L: float, undetermined=None,
                          **kw) -> tuple:
    """``(std_before (6,), std_after (k, 6))``: predicted 1-sigma per axis with the recorded
    information ``F_base`` and after each stop's information ``added`` (with ``sysm``, the
    systematic scores: ``sysm[0]`` the recorded one, ``added_g`` each stop's); the axes
    the ``undetermined`` directions touch are undetermined (inf)."""
    def std(F, G):
        if sysm is None:
            return info.predicted_std(F, range_m=L, undetermined=undetermined, **kw)
        return info.systematic_std(F, G, range_m=L, undetermined=undetermined, **kw)

    F = np.asarray(F_base, dtype=np.float64).copy()
    G = sysm[0].copy() if sysm is not None else None
    after = []
    for j, Fa in enumerate(added):
        F = F + Fa
        G = G + added_g[j] if G is not None else None
        after.append(std(F, G))
    return std(F_base, None if sysm is None else sysm[0]), np.array(after).reshape(-1, 6)


def random_chains(F_base, motion_a, X, s_r, s_t, usable, k: int, rng, *, noise_scale,
                  systematic, range_m: float, n: int = N_RANDOM_CHAINS, undetermined=None,
                  **kw) -> tuple:
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
    kw = dict(kw, range_m=range_m, undetermined=undetermined)
    if systematic is None:
        std = [info.predicted_std(f, **kw) for f in F]
    else:
        std = [info.systematic_std(f, g, **kw) for f, g in zip(F, G)]
    return chains, np.array(std)


def expected_gain(adv) -> dict:
    """The planner's own expectation of what its choice gains (no simulation): the advised
    chain's largest predicted 1-sigma (deg, cm; apart from the axes no motion of the
    platform determines, ``cannot_help``) against the median over
    :attr:`Advice.random_chains` (random stops from the same candidates); empty without
    them."""
    if adv.random_chains_std is None or len(adv.std_after) == 0:
        return {}
    skip = cannot_help_axes(adv.cannot_help)
    adv_deg, adv_cm = (float(x) for x in info.largest_std(adv.std_after[-1], skip))
    r_deg, r_cm = info.largest_std(adv.random_chains_std, skip)
    rnd_deg, rnd_cm = float(np.median(r_deg)), float(np.median(r_cm))

    def ratio(x, y):
        return x / y if np.isfinite(x) and np.isfinite(y) and y > 0 else None
    f = info.finite_or_none
    return {"chains": int(r_deg.shape[0]), "stops": int(adv.random_chains.shape[1]),
            "advised_max_std_deg": f(adv_deg), "advised_max_std_cm": f(adv_cm),
            "random_max_std_deg_median": f(rnd_deg), "random_max_std_cm_median": f(rnd_cm),
            "expected_ratio_rotation": f(ratio(adv_deg, rnd_deg)),
            "expected_ratio_translation": f(ratio(adv_cm, rnd_cm))}


def view_noise_scale(world, cand, aruco_cameras, lens, view_weighting: bool = True
                     ) -> np.ndarray:
    """``(N,)`` pose-noise variance factor of each candidate stop from the worst ArUco view:
    ``(q_ref / q)**2`` clipped to [1/4, 4] (:func:`feasibility.view_quality`)."""
    scale = np.ones(cand.n)
    if view_weighting and aruco_cameras:
        for c in aruco_cameras:
            q_ref = fz.view_quality(world, cand.ref["T_world_cam"][c][None], c, lens)[0]
            q = fz.view_quality(world, cand.T_world_cam[c], c, lens)
            f = np.clip((q_ref / np.maximum(q, 1e-9)) ** 2, 0.25, 4.0)
            scale = np.maximum(scale, f) if c != aruco_cameras[0] else f
    return scale


def usable(cand, rejected) -> np.ndarray:
    """``(N,)`` feasible candidates the render check did not reject."""
    out = cand.feasible.copy()
    out[list(rejected)] = False
    return out


@dataclass(frozen=True)
class _Model:
    """What the choice weighs about the candidates: their information ``F`` (N, 6, 6), the
    pose-noise factor of each stop ``scale``, the systematic errors ``sysm`` (None: none)
    and their column ``groups``, the directions no feasible candidate determines (``U``
    (6, r) tolerance units, None: none) and their statements ``cannot``."""
    F: np.ndarray
    scale: np.ndarray
    sysm: tuple | None
    groups: list
    U: np.ndarray | None
    cannot: list


def _candidate_model(world, cand, C, H, X, s_r, s_t, F_base, L, lens, opts, kw) -> _Model:
    """The :class:`_Model` of the candidates ``cand`` (``opts``: aruco_cameras,
    view_weighting, pose_error_basis, run_cfg, sources of :func:`advise_motions`)."""
    Cc, Hc = info.predicted_motions(cand.motion["cam_a"], X)
    F_cand = info.motion_information(Cc, Hc, X, s_r, s_t)
    scale = view_noise_scale(world, cand, opts["aruco_cameras"], lens, opts["view_weighting"])
    sysm, groups = None, []
    if opts["pose_error_basis"] is not None and opts["run_cfg"] is not None \
            and opts["sources"]:
        sysm, groups = systematic_model(world, cand, C, H, X, s_r, s_t,
                                        opts["pose_error_basis"], dict(opts["sources"]),
                                        opts["run_cfg"])
    U = info.undeterminable_directions(F_base, F_cand, feasible=cand.feasible, range_m=L,
                                       **kw)
    hint = fz.tilt_hint(world.config)
    cannot = [info.describe_direction(u, tilt_hint=hint) for u in U.T]
    return _Model(F_cand, scale, sysm, groups, U if U.shape[1] else None, cannot)


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
    ``"wide"``: the arm's flange rotated up to 90 deg — about the vertical only for a
    SCARA — and moved up to 30 cm; ``cand_kw`` overrides the maxima); with ``run_cfg``,
    the ArUco cameras' markers are counted in the image their lens forms
    (:func:`feasibility.lens_distortion`).

    Directions no feasible candidate determines are stated (``cannot_help``), reported
    undetermined, and left out of the choice: the stops are ranked by what they can
    improve (:func:`information.undeterminable_directions`).

    ``when_determined``: when the recorded motions already determine every direction of X
    within the tolerance (largest predicted 1-sigma <= 1 tolerance), ``"advise"``
    (default) still proposes the ``k`` stops that lower it most and says so in
    ``message``; ``"stop"`` proposes none.

    ``view_weighting``: scale each candidate stop's pose-noise variance by how much worse
    (or better) the ArUco cameras' view of the markers is there than at the reference
    (:func:`view_noise_scale`); ``refine``: exchange passes after the greedy choice.

    ``pose_error_basis``: ``(Ba, Bb, pose_pairs)`` of the recorded datapoints (full layout of
    :func:`simcalib.pipeline.uncertainty_inputs.pose_error_basis`, ``compress=False``) with ``run_cfg`` (the
    run's ScenarioConfig) and ``sources`` (camera -> source name): the systematic pose
    errors (marker map and calibrations for ArUco cameras, the arm's DH table for
    ``robot_fk``) are then part of the choice and of the predicted 1-sigma
    (:func:`systematic.systematic_model`, :func:`planner.greedy_chain` ``systematic``)."""
    check_when_determined(when_determined)
    t0 = time.perf_counter()
    kw = dict(tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)
    s_r, s_t, F_base, L = recorded_information(C, H, X, alpha, **kw)
    t1 = time.perf_counter()
    lens = fz.lens_distortion(run_cfg) if aruco_cameras else None
    cand = fz.candidates(world, n_candidates, rng, aruco_cameras=aruco_cameras, ranges=ranges,
                         **{"distortion": lens, **cand_kw})
    t2 = time.perf_counter()
    opts = dict(aruco_cameras=aruco_cameras, view_weighting=view_weighting,
                pose_error_basis=pose_error_basis, run_cfg=run_cfg, sources=sources)
    m = _candidate_model(world, cand, C, H, X, s_r, s_t, F_base, L, lens, opts, kw)
    message, propose = determined_message(F_base, when_determined, **kw)
    feasible = cand.feasible.copy() if propose else np.zeros_like(cand.feasible)
    choice = _choose_render_checked(F_base, cand, X, s_r, s_t, k, feasible, m, refine,
                                    render_check, aruco_cameras, kw)
    t3 = time.perf_counter()
    return _advice(cand, F_base, X, (s_r, s_t), L, int(k), m, choice, message, rng, kw,
                   {"information": t1 - t0, "candidates": t2 - t1,
                    "choice_and_render_check": t3 - t2, "_t0": t0})


def _advice(cand, F_base, X, noise, L, k, m: _Model, choice, message, rng, kw,
            timing) -> Advice:
    """The :class:`Advice` of a chosen chain: the predicted 1-sigma along it, what limits
    it, and random chains of the same candidates to compare with."""
    g, added, added_g, rejected, checked = choice
    before, after = predicted_along_chain(F_base, added, added_g, m.sysm, L, m.U, **kw)
    chains, chains_std = random_chains(F_base, cand.motion["cam_a"], X, *noise,
                                       usable(cand, rejected), int(g.order.size), rng,
                                       noise_scale=m.scale, systematic=m.sysm, range_m=L,
                                       undetermined=m.U, **kw)
    limit = {} if m.sysm is None else limited_by(
        F_base + added.sum(axis=0), m.sysm[0] + added_g.sum(axis=0), m.groups,
        after[-1] if len(after) else before, range_m=L, exclude=cannot_help_axes(m.cannot),
        undetermined=m.U, **kw)
    t0 = timing.pop("_t0")
    return Advice(k=k, candidates=cand, chosen=g.order, std_before=before, std_after=after,
                  max_std_tol=g.max_std_tol, criterion=g.criterion, noise=noise,
                  tolerance_deg=kw["tolerance_deg"], tolerance_m=kw["tolerance_m"],
                  cannot_help=m.cannot, undetermined=m.U, render_check=checked,
                  rejected_by_render=tuple(rejected), F_base=F_base, F_cand=m.F, X=X,
                  message=message, noise_scale=m.scale,
                  systematic_parameters=0 if m.sysm is None else int(m.sysm[0].shape[1]),
                  limited_by=limit, random_chains=chains, random_chains_std=chains_std,
                  timing_s={**timing, "total": time.perf_counter() - t0})


def _choose_render_checked(F_base, cand, X, s_r, s_t, k, feasible, m: _Model, refine,
                           render_check, aruco_cameras, kw) -> tuple:
    """The chain, chosen again without the stops the render check finds unmeasured (at most
    4 rounds; if the last still finds some, chosen among the stops the renders measured):
    ``(g, added, added_g, rejected, markers per chosen stop and camera)``."""
    def choose(feas):
        return pl.greedy_chain_systematic(
            F_base, cand.motion["cam_a"], X, s_r, s_t, k, feasible=feas,
            noise_scale=m.scale, refine=refine, systematic=m.sysm, undetermined=m.U, **kw)
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


def advise(base: Baseline, k: int = 5, *, seed: int = 0, n_candidates: int = N_CANDIDATES,
           tolerance_deg: float = 1.0, tolerance_m: float = 0.01, render: bool = True,
           when_determined: str = "advise", systematic: bool = True, **cand_kw) -> Advice:
    """Advice for a :class:`Baseline` (candidates drawn from ``seed``); ``systematic``: weigh
    the recorded run's systematic pose errors (``base.pose_error_basis``) in the choice."""
    rng = np.random.default_rng([int(seed), 13])
    rc_rng = np.random.default_rng([int(seed), 17])

    def check(cand, idx):
        return execute_stops(base.truth, base.cfg, cand, idx, rc_rng)

    return advise_motions(base.truth.world, base.C, base.H, base.X, k, rng=rng,
                          alpha=base.alpha, n_candidates=n_candidates,
                          aruco_cameras=base.aruco_cameras, tolerance_deg=tolerance_deg,
                          tolerance_m=tolerance_m, render_check=check if render else None,
                          when_determined=when_determined,
                          pose_error_basis=base.pose_error_basis if systematic else None,
                          run_cfg=base.cfg, sources=base.sources, **cand_kw)


def random_baseline_candidates(base: Baseline, n: int = 300) -> fz.Candidates:
    """The random baseline's own feasible set: ``n`` stops drawn with the ``"jog"`` ranges
    (arm 5-40 deg, 15 cm — about the vertical only for a SCARA; cart +-90 deg, 1 m)
    whatever ranges the planner was given, from the scenario's seed (the same set for
    every verification of a run)."""
    return fz.candidates(base.truth.world, n, np.random.default_rng([int(base.cfg.seed), 13]),
                         aruco_cameras=base.aruco_cameras, ranges="jog",
                         distortion=fz.lens_distortion(base.cfg))
