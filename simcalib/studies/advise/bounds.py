"""How far a choice of the advice's candidates could get: the hindsight bound (the stops a
chooser that knew the true X would visit, measured, :func:`hindsight_stops`), how well
the prediction ranks chains by their actual errors (:func:`ranking_agreement`), and the
model's floor (the best chain the planner's own error model knows of,
:func:`choice_floor`). None of these is advice: they say how much better a choice could
be."""

from __future__ import annotations

import numpy as np

import simcalib.studies.advise.feasibility as fz
import simcalib.studies.advise.planner as pl
from simcalib.studies.advise.advisor import (N_RANDOM_CHAINS, random_baseline_candidates,
                                             usable, view_noise_scale)
from simcalib.studies.advise.information import AXES, finite_or_none
from simcalib.studies.advise.outcomes import errors_against, undetermined_translations
from simcalib.studies.advise.stops import execute_stops
from simcalib.studies.advise.systematic import cannot_help_axes, systematic_model

__all__ = ["hindsight_stops", "ranking_agreement", "choice_floor", "N_FLOOR_STARTS"]

#: random starts of :func:`choice_floor`'s search (besides the planner's chain)
N_FLOOR_STARTS = 6


def hindsight_stops(base, cand, k: int, rng: np.random.Generator, *, scale=(1.0, 1.0),
                    chains=None, chains_std=None, cannot_help=()) -> dict:
    """The ``k`` stops of ``cand`` a chooser that knew the true X would visit: **not
    advice** (no planner has the truth) but what these candidates can give on this rig
    (greedy, so the best choice of ``k`` of them does at least as well: an upper bound on
    the smallest reachable error). Every feasible candidate is measured once (the rig of
    the recorded run ``base``, per-frame noise from ``rng``), then stops are added greedily
    (stop and go, from the reference), each the one whose chain gives dqopt the smallest
    ``max(rotation error / scale[0] deg, translation error / scale[1] cm)`` against the
    true X (the translation along the ``cannot_help`` directions left out, as the
    verification measures it). Returns ``stops`` (candidate indices, in order),
    ``rotation_error_deg``, ``translation_error_cm``, ``success``, ``measured``
    (candidates measured); with ``chains`` ``(n, k)`` and their predicted 1-sigma
    ``chains_std`` ``(n, 6)`` (:attr:`Advice.random_chains`) also ``ranking``
    (:func:`ranking_agreement`): how well the planner's prediction ranks those chains by
    their actual errors."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an integer >= 1; received {k!r}")
    s_deg, s_cm = (float(x) for x in scale)
    if not (s_deg > 0 and s_cm > 0 and np.isfinite(s_deg) and np.isfinite(s_cm)):
        raise ValueError(f"scale must be two positive numbers (deg, cm); received {scale!r}")
    feas = np.flatnonzero(cand.feasible)
    pose = _measured_poses(execute_stops(base.truth, base.cfg, cand, feas, rng))
    ok = [f for f in pose["cam_a"] if f in pose["cam_b"]]
    if 0 not in ok:
        return {"success": False, "stops": [], "measured": 0}
    errors = _chain_errors(base, pose, undetermined_translations(cannot_help))
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
           "rotation_error_deg": finite_or_none(best[0]),
           "translation_error_cm": finite_or_none(best[1]), "measured": int(len(ok) - 1)}
    if chains is not None and chains_std is not None:
        out["ranking"] = _ranking_of_chains(chains, chains_std, feas, pose, errors,
                                            cannot_help_axes(cannot_help))
    return out


def _measured_poses(streams) -> dict:
    """camera -> {stop frame: pose} of the measured stops."""
    return {cam: {int(f): T for f, T in zip(np.asarray(streams[cam].frame_index),
                                             np.asarray(streams[cam].T_world_cam))}
            for cam in ("cam_a", "cam_b")}


def _chain_errors(base, pose, undetermined):
    """``errors(frames) -> (rotation deg, translation cm)``: dqopt's errors against the true
    X with the recorded motions and the chain of measured stops ``frames`` (inf when it
    fails)."""
    from simcalib.geometry import invert_transform
    from simcalib.solvers.api import solve

    def errors(frames):
        prev = [0] + frames[:-1]
        C = [invert_transform(pose["cam_a"][p]) @ pose["cam_a"][f] for p, f in zip(prev, frames)]
        H = [invert_transform(pose["cam_b"][p]) @ pose["cam_b"][f] for p, f in zip(prev, frames)]
        sol = solve(np.concatenate([base.C, C]), np.concatenate([base.H, H]),
                    method="dqopt", alpha=base.alpha)
        X = np.asarray(sol.X, dtype=np.float64)
        if not sol.success or not np.isfinite(X).all():
            return np.inf, np.inf
        e = errors_against(X, base.truth.X_true, undetermined)
        return e["rotation_error_deg"], e["translation_error_cm"]
    return errors


def _ranking_of_chains(chains, chains_std, feas, pose, errors, skip) -> dict:
    """:func:`ranking_agreement` of the ``chains`` whose stops were all measured (the axes
    ``skip`` left out of the prediction, as they are of the errors)."""
    frame = {int(c): j + 1 for j, c in enumerate(feas)}
    keep, actual = [], []
    for i, ch in enumerate(np.asarray(chains)):
        fr = [frame.get(int(c), -1) for c in ch]
        if all(f in pose["cam_a"] and f in pose["cam_b"] for f in fr):
            keep.append(i)
            actual.append(errors(fr))
    return ranking_agreement(np.asarray(chains_std)[keep], np.array(actual).reshape(-1, 2),
                             skip=skip)


def ranking_agreement(predicted_std, actual, skip=()) -> dict:
    """How well predicted 1-sigma ``(n, 6)`` (deg, m per axis) rank ``n`` chains by their
    actual errors ``(n, 2)`` (rotation deg, translation cm): per block, Spearman's rank
    correlation of the predicted error size (root sum of the axes' variances: the expected
    norm) with the actual error, and the median actual error of the tenth best-predicted
    chains over that of all (1: the prediction picks no better than chance). ``None``
    where a block is undetermined for some chain or fewer than 10 chains were measured.
    ``skip``: axes (:data:`information.AXES`) left out of the predicted size (those no
    motion of the platform determines, which the actual errors leave out too)."""
    from scipy.stats import spearmanr
    P = np.where(np.isin(AXES, list(skip)), 0.0, np.asarray(predicted_std, dtype=np.float64))
    A = np.asarray(actual, dtype=np.float64)
    out = {"chains": int(A.shape[0])}
    for b, name in ((0, "rotation"), (1, "translation")):
        pred = np.sqrt(np.sum(P[:, 3 * b:3 * b + 3] ** 2, axis=1))
        act = A[:, b]
        if A.shape[0] < 10 or not (np.isfinite(pred).all() and np.isfinite(act).all()):
            out[f"spearman_{name}"] = out[f"best_tenth_over_all_{name}"] = None
            continue
        best = pred <= np.quantile(pred, 0.1)
        out[f"spearman_{name}"] = finite_or_none(spearmanr(pred, act).statistic)
        out[f"best_tenth_over_all_{name}"] = finite_or_none(np.median(act[best])
                                                            / np.median(act))
    return out


def choice_floor(base, adv, *, n_starts: int = N_FLOOR_STARTS, n_random: int = 300,
                 n_chains: int = N_RANDOM_CHAINS) -> dict:
    """How much any choice of stops can gain, by the planner's own model (no simulation):
    the expected error of X (root-mean-square norm of its rotation, deg, and of its
    translation, cm: white noise and the shared pose errors) after the advised stops;
    the smallest a chain of ``adv.k`` of the advice's usable candidates reaches, as far as
    :func:`planner.best_expected_chains` finds (rotation and translation each searched on
    its own, from the planner's chain and ``n_starts`` random chains); and the median over
    ``n_chains`` chains of ``adv.k`` random stops of the verification's random baseline
    (:func:`advisor.random_baseline_candidates`, ``n_random`` drawn). A *floor* ratio
    above a target says that no choice among these candidates the search finds can be
    expected to reach it on a rig of this kind: only knowing this rig's shared errors
    (the hindsight bound of :func:`hindsight_stops`) could. Directions no feasible
    candidate determines (``adv.cannot_help``, e.g. a cart's vertical translation) are
    left out: each block is judged on the directions the candidates determine. Empty
    when the advice proposes fewer than ``k`` stops."""
    k = int(adv.chosen.size)
    if k < 1 or k != adv.k:
        return {}
    kw = dict(tolerance_deg=adv.tolerance_deg, tolerance_m=adv.tolerance_m,
              undetermined=adv.undetermined)
    rng = np.random.default_rng([int(base.cfg.seed), 707])
    cand = adv.candidates
    sysm, scale = _floor_model(base, adv, cand)
    idx = np.flatnonzero(usable(cand, adv.rejected_by_render))
    starts = np.concatenate([adv.chosen[None]] + [rng.choice(idx, k, replace=False)[None]
                                                  for _ in range(int(n_starts))])
    best = pl.best_expected_chains(adv.F_base, cand.motion["cam_a"], adv.X, *adv.noise,
                                   starts, feasible=usable(cand, adv.rejected_by_render),
                                   noise_scale=scale, systematic=sysm, **kw)
    F, G = pl.chain_information(adv.F_base, cand.motion["cam_a"], adv.X, *adv.noise,
                                adv.chosen[None], noise_scale=scale, systematic=sysm)
    advised = pl.expected_errors(F, G, **kw)[0]
    rc = random_baseline_candidates(base, n_random)
    sysm_r, scale_r = _floor_model(base, adv, rc)
    feas = np.flatnonzero(rc.feasible)
    if feas.size < k:
        return {}
    chains = np.stack([rng.choice(feas, k, replace=False) for _ in range(int(n_chains))])
    F, G = pl.chain_information(adv.F_base, rc.motion["cam_a"], adv.X, *adv.noise, chains,
                                noise_scale=scale_r, systematic=sysm_r)
    rand = np.median(pl.expected_errors(F, G, **kw), axis=0)
    out = {"stops": k, "starts": int(starts.shape[0]), "random_chains": int(chains.shape[0])}
    out.update(_floor_blocks(best, advised, rand))
    out["floor_chains"] = {"rotation": best["rotation"]["chain"],
                           "translation": best["translation"]["chain"]}
    return out


def _floor_model(base, adv, cand) -> tuple:
    """``(systematic, noise_scale)`` of the candidates ``cand`` for the advice's model."""
    sysm = None if base.pose_error_basis is None else systematic_model(
        base.truth.world, cand, base.C, base.H, adv.X, *adv.noise, base.pose_error_basis,
        base.sources, base.cfg)[0]
    lens = fz.lens_distortion(base.cfg)
    return sysm, view_noise_scale(base.truth.world, cand, base.aruco_cameras, lens, True)


def _floor_blocks(best, advised, rand) -> dict:
    """The floor's numbers per block (rotation deg, translation cm), on the directions the
    candidates determine."""
    out = {}
    f = finite_or_none
    for b, (name, unit, to_unit) in enumerate((("rotation", "deg", 1.0),
                                               ("translation", "cm", 100.0))):
        res = best[name]
        floor = res["expected_deg" if b == 0 else "expected_m"]
        per = res["per_start_deg" if b == 0 else "per_start_m"]
        out.update({
            f"advised_expected_{unit}": f(to_unit * advised[b]),
            f"floor_expected_{unit}": f(to_unit * floor),
            f"random_expected_{unit}": f(to_unit * rand[b]),
            f"ratio_advised_{name}": f(advised[b] / rand[b]),
            f"ratio_floor_{name}": f(floor / rand[b]),
            f"floor_per_start_{unit}": [to_unit * float(v) for v in per]})
    return out
