"""Verification of advice in simulation: the advised stops and random stops are measured
by the scenario's pose sources with the recorded run's rig (:mod:`simcalib.studies.advise.
stops`), appended to the recorded motions and solved with dqopt; the errors against the
true X are compared over several measurement seeds (:func:`verify`)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

import simcalib.studies.advise.feasibility as fz
from simcalib.studies.advise.advisor import random_baseline_candidates
from simcalib.studies.advise.bounds import hindsight_stops
from simcalib.studies.advise.outcomes import (median_size, median_summary, motion_size,
                                              solve_errors)
from simcalib.studies.advise.stops import execute_stops, stop_motions, stop_state
from simcalib.studies.advise.systematic import stop_bases

__all__ = ["Verification", "verify"]


@dataclass(frozen=True)
class Verification:
    """Actual errors and predicted 1-sigma of dqopt for ``baseline``, ``advised`` and each
    ``random`` seed (dicts of :func:`outcomes.solve_errors` plus ``stops_measured``), the medians
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


def verify(base, adv, *, seeds=(0, 1, 2, 3, 4), joint_baseline: bool = True,
           max_joint_deg: float = 20.0, n_joint: int = 300, n_random: int = 300,
           wide_baseline: bool = True, frames_per_stop: int = 1,
           hindsight: bool = False) -> Verification:
    """Execute the advised stops of ``adv`` (after ``base``'s recorded run) and
    ``len(seeds)`` sets of ``k`` random feasible stops in the simulator; solve with each
    added (:func:`outcomes.solve_errors`: the directions no motion of the platform
    determines, ``adv.cannot_help``, left out of the errors). Random baselines:
    ``random``, uniform over ``n_random`` feasible stops drawn by
    :func:`feasibility.candidates` with the ``"jog"`` ranges (arm: flange rotated 5-40 deg
    about a uniform axis — the vertical for a SCARA — moved up to 15 cm; cart: yaw +-90
    deg, 1 m; never screened by information); for a 6-DoF arm with ``joint_baseline``,
    ``random_joint``: ``k`` feasible stops of ``n_joint`` joint jogs of
    +-``max_joint_deg`` per joint around the reference
    (:func:`feasibility.joint_candidates`); with ``wide_baseline``, ``random_wide``: ``k``
    stops uniform over the planner's own feasible candidates. ``frames_per_stop``: frames
    recorded and averaged at each stop, for every set of stops alike
    (:func:`stops.execute_stops`). ``hindsight``: also the bound of
    :func:`bounds.hindsight_stops` on the planner's candidates (measured with the first
    seed's noise, scored against the random medians)."""
    t0 = time.perf_counter()
    run = _Runner(base, adv, frames_per_stop)
    res0 = run.recorded()
    res_adv, res_adv_seeds = _advised_runs(run, adv, seeds, res0)
    adv_med, _ = median_summary({}, res_adv_seeds)
    res_rand = run.random(random_baseline_candidates(base, n_random), seeds, 202)
    med, ratio = median_summary(adv_med, res_rand)
    res_joint, med_j, ratio_j = [], {}, {}
    if joint_baseline and adv.k > 0 and _can_jog(adv.candidates, base.truth.world):
        jc = fz.joint_candidates(base.truth.world, n_joint,
                                 np.random.default_rng([int(base.cfg.seed), 404]),
                                 aruco_cameras=base.aruco_cameras, max_joint_deg=max_joint_deg,
                                 distortion=fz.lens_distortion(base.cfg))
        res_joint = run.random(jc, seeds, 505)
        med_j, ratio_j = median_summary(adv_med, res_joint)
    res_wide, med_w, ratio_w = [], {}, {}
    if wide_baseline and adv.k > 0:
        res_wide = run.random(adv.candidates, seeds, 606)
        med_w, ratio_w = median_summary(adv_med, res_wide)
    hind, ratio_h = {}, {}
    if hindsight and adv.k > 0 and med.get("rotation_error_deg") and \
            med.get("translation_error_cm"):
        hind = hindsight_stops(base, adv.candidates, adv.k,
                               np.random.default_rng([int(seeds[0]), 303]),
                               scale=(med["rotation_error_deg"], med["translation_error_cm"]),
                               chains=adv.random_chains, chains_std=adv.random_chains_std,
                               cannot_help=adv.cannot_help)
        _, ratio_h = median_summary(hind, res_rand)
    size = {"advised": res_adv.get("motion_size"),
            "random": median_size([r.get("motion_size") for r in res_rand]),
            "random_joint": median_size([r.get("motion_size") for r in res_joint]),
            "random_wide": median_size([r.get("motion_size") for r in res_wide])}
    return Verification(res0, res_adv, res_rand, med, ratio,
                        {"verification": time.perf_counter() - t0}, res_joint, med_j,
                        ratio_j, size, res_adv_seeds, adv_med, res_wide, med_w, ratio_w,
                        frames_per_stop=int(frames_per_stop), hindsight=hind,
                        ratio_hindsight=ratio_h)


def _can_jog(cand, world) -> bool:
    """Whether the joint-jog baseline applies: a 6-DoF arm (a cart has no joints, and
    jogging the UR5e's joints tilts the flange, which a SCARA cannot)."""
    return cand.platform == "arm" and fz.rotation_axes(world.config) == "any"


class _Runner:
    """Measures sets of stops after the recorded run of ``base`` and solves with them."""

    def __init__(self, base, adv, frames_per_stop: int):
        self.base, self.adv, self.frames = base, adv, frames_per_stop
        self.kw = dict(tolerance_deg=adv.tolerance_deg, tolerance_m=adv.tolerance_m,
                       cannot_help=adv.cannot_help)

    def recorded(self) -> dict:
        """dqopt on the recorded motions alone (with their systematic errors)."""
        b = self.base
        rec = {} if b.pose_error_basis is None else {
            "pose_pairs": b.pose_error_basis[2], "pose_error_basis": b.pose_error_basis[:2]}
        return solve_errors(b.C, b.H, b.truth.X_true, b.alpha, **self.kw, **rec)

    def __call__(self, idx, rng, cand=None) -> dict:
        """The stops ``idx`` of ``cand`` (default: the advice's) measured with ``rng``."""
        b = self.base
        cand = self.adv.candidates if cand is None else cand
        streams = execute_stops(b.truth, b.cfg, cand, idx, rng, frames_per_stop=self.frames)
        Cs, Hs, got = stop_motions(streams, chain=True)
        r = solve_errors(np.concatenate([b.C, Cs]), np.concatenate([b.H, Hs]),
                         b.truth.X_true, b.alpha, **self.kw,
                         **_systematic_inputs(b, cand, idx, streams, got))
        r["stops_measured"] = int(got.size)
        r["stops"] = [int(i) for i in idx]
        r["motion_size"] = motion_size(cand, idx)
        return r

    def random(self, cands, seeds, salt: int) -> list[dict]:
        """k random feasible stops of ``cands`` per seed (choice drawn with ``salt``)."""
        feas = np.flatnonzero(cands.feasible)
        out = []
        for s in seeds if feas.size else ():
            rng = np.random.default_rng([int(s), salt])
            idx = rng.choice(feas, size=min(self.adv.k, feas.size), replace=False)
            r = self(idx, np.random.default_rng([int(s), 303]), cands)
            r["seed"] = int(s)
            out.append(r)
        return out


def _advised_runs(run: _Runner, adv, seeds, res0) -> tuple[dict, list]:
    """The advised stops measured once with the scenario's seed and once per seed (the
    random draws of seed s use the same measurement stream: common random numbers)."""
    if not adv.chosen.size:                     # advice: no motion needed
        return (dict(res0, stops_measured=0, stops=[]),
                [dict(res0, stops_measured=0, stops=[], seed=int(s)) for s in seeds])
    res_adv = run(adv.chosen, np.random.default_rng([run.base.cfg.seed, 101]))
    res_seeds = []
    for s in seeds:
        r = run(adv.chosen, np.random.default_rng([int(s), 303]))
        r["seed"] = int(s)
        res_seeds.append(r)
    return res_adv, res_seeds


def _systematic_inputs(base, cand, idx, streams, got) -> dict:
    """``pose_pairs`` / ``pose_error_basis`` of the recorded motions followed by the chain of
    measured stops (datapoint ``D`` the reference, ``D + j + 1`` the ``j``-th measured
    stop; :func:`stops.stop_motions` chains the measured ones), so that the
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
    stops = stop_bases(base.truth.world, base.cfg, base.sources, T,
                       stop_state(cand, idx)[0][frames], Ba.shape[2])
    row = np.arange(1, got.size + 1)              # stop got[j] is row j + 1 (0: reference)
    chain = np.stack([D + row - 1, D + row], axis=1)
    return {"pose_pairs": np.concatenate([pairs, chain]),
            "pose_error_basis": (np.concatenate([Ba, stops[0]]),
                                 np.concatenate([Bb, stops[1]]))}
