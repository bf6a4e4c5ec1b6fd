"""Motion advice with systematic pose errors (issue 13): the adjoint, the arm's DH-error
basis, the systematic score of a motion, the covariance criterion and the chain choice
that weighs them (simcalib.studies.advise.planner, simcalib.world.robot_error)."""

import numpy as np
import pytest

from simcalib import geometry as g
from simcalib.studies.advise import information as info
from simcalib.studies.advise import planner as pl
from simcalib.solvers.diagnostics.uncertainty import linear_model


def _exp6(xi):
    xi = np.asarray(xi, dtype=np.float64)
    T = np.zeros(xi.shape[:-1] + (4, 4))
    T[..., :3, :3] = g.matrix_from_rotvec(xi[..., :3])
    T[..., :3, 3] = xi[..., 3:]
    T[..., 3, 3] = 1.0
    return T


def _log6(T):
    return np.concatenate([g.rotvec_from_matrix(T[..., :3, :3]), T[..., :3, 3]], -1)


def _X():
    return _exp6([0.1, -0.2, 0.3, 0.05, -0.09, 0.06])


def _motions(rng, n, max_angle=0.6, trans=0.2):
    ax = rng.standard_normal((n, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    return _exp6(np.concatenate([ax * rng.uniform(0.5 * max_angle, max_angle, (n, 1)),
                                 rng.normal(0, trans, (n, 3))], 1))


def test_adjoint_moves_a_twist_through_a_transform():
    rng = np.random.default_rng(0)
    T = _motions(rng, 4)
    xi = rng.normal(0, 1e-5, (4, 6))
    lhs = _log6(T @ _exp6(xi) @ g.invert_transform(T))
    rhs = np.einsum("nij,nj->ni", g.adjoint_from_transform(T), xi)
    # first order (this exp is [exp(omega) | v], not the screw exponential)
    np.testing.assert_allclose(lhs, rhs, atol=1e-9)


def test_dh_error_basis_matches_the_reported_pose_error():
    from simcalib.world.robot_error import UR5E_DH, dh_fk, fk_pose_error_basis
    rng = np.random.default_rng(1)
    q = rng.uniform(-2, 2, (5, 6))
    T_fc = _exp6([0.1, -0.05, 0.2, 0.0, -0.09, 0.06])
    sig = np.array([1e-3, 1e-3, 1e-3, 1e-3])
    B = fk_pose_error_basis(q, T_fc, sig)
    assert B.shape == (5, 6, 24)
    delta = rng.standard_normal((6, 4)) * sig
    T_rep = dh_fk(q, UR5E_DH) @ T_fc               # what the controller reports
    T_true = dh_fk(q, UR5E_DH + delta) @ T_fc      # where the camera is
    exact = _log6(g.invert_transform(T_true) @ T_rep)
    lin = B @ (delta / sig).ravel()
    assert np.abs(lin - exact).max() < 0.02 * np.abs(exact).max()
    assert not fk_pose_error_basis(q, T_fc, [0.0, 0.0, 1e-3, 0.0])[:, :, 0::4].any()
    with pytest.raises(ValueError, match="sigmas must be 4"):
        fk_pose_error_basis(q, T_fc, sig[:3])
    with pytest.raises(ValueError, match=r"q must be \(N, 6\)"):
        fk_pose_error_basis(q[:, :5], T_fc, sig)


def test_systematic_scores_match_finite_differences_of_the_score():
    """The score K^T Q^-1 e of a motion whose two stops carry errors B eta, against
    recomputing it on the perturbed motions."""
    rng = np.random.default_rng(2)
    X = _X()
    Ta = _motions(rng, 6)                      # poses of camera a at 6 stops
    Tb = Ta @ X
    k = np.arange(5)
    P = 7
    Ba = rng.normal(0, 1, (6, 6, P))
    Bb = rng.normal(0, 1, (6, 6, P))
    C = g.invert_transform(Ta[k]) @ Ta[k + 1]
    H = g.invert_transform(Tb[k]) @ Tb[k + 1]
    s_r, s_t = 0.01, 0.002
    G = info.systematic_scores(C, H, X, s_r, s_t, Ba[k], Ba[k + 1], Bb[k], Bb[k + 1])
    assert G.shape == (5, 6, P)

    def score(eta):
        Pa = Ta @ _exp6(Ba @ eta)
        Pb = Tb @ _exp6(Bb @ eta)
        Cp = g.invert_transform(Pa[k]) @ Pa[k + 1]
        Hp = g.invert_transform(Pb[k]) @ Pb[k + 1]
        e, K, Qr, Qt = linear_model(Cp, Hp, X)
        _, K0, Qr0, Qt0 = linear_model(C, H, X)    # weights at the unperturbed motions
        Q = (s_r ** 2 + info.ROTATION_FLOOR_RAD ** 2) * Qr0 + (s_t ** 2 + (1e-9 * 0.1) ** 2) * Qt0
        return np.einsum("nki,nkl,nl->ni", K0, np.linalg.inv(Q), e)

    h = 1e-6
    for p in range(P):
        eta = np.zeros(P)
        eta[p] = h
        fd = (score(eta) - score(-eta)) / (2 * h)
        np.testing.assert_allclose(G[:, :, p], fd, rtol=2e-4, atol=1e-6 * np.abs(fd).max())


def test_criterion_and_std_reduce_to_the_information_ones_without_systematic_errors():
    rng = np.random.default_rng(3)
    X = _X()
    C = _motions(rng, 20)
    F = info.motion_information(C, g.invert_transform(X) @ C @ X, X, 0.005, 0.001).sum(0)
    dsc = info.tolerance_scale(1.0, 0.01)
    Ft = F * np.outer(dsc, dsc)
    assert pl._criterion_systematic(Ft, np.zeros((6, 3))) == pytest.approx(
        float(pl._criterion(Ft)), rel=1e-9)
    np.testing.assert_allclose(info.systematic_std(F, np.zeros((6, 3))), info.predicted_std(F),
                               rtol=1e-9)
    Gs = rng.normal(0, 10.0, (6, 3))
    assert np.all(info.systematic_std(F, Gs) >= info.predicted_std(F) * (1 - 1e-12))


def test_chain_choice_weighs_systematic_errors_and_never_raises_the_criterion():
    rng = np.random.default_rng(4)
    X = _X()
    Cb = _motions(rng, 30, max_angle=0.05)                   # nearly degenerate record
    Fb = info.motion_information(Cb, g.invert_transform(X) @ Cb @ X, X, 0.005, 0.001).sum(0)
    M = _motions(rng, 40)
    P = 5
    zero = (np.zeros((6, P)), np.zeros((2, 6, P)), np.zeros((2, 40, 6, P)))
    g0, a0 = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 4)
    g1, a1 = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 4, systematic=zero)
    assert g1.order.tolist() == g0.order.tolist()          # no systematic error: the same
    np.testing.assert_allclose(g1.criterion, g0.criterion, rtol=1e-6)
    # the stop the plain choice likes best carries a huge systematic error: avoided
    Bc = np.zeros((2, 40, 6, P))
    Bc[:, g0.order[0]] = rng.normal(0, 0.05, (2, 6, P))
    g2, _ = pl.greedy_chain(Fb, M, X, 0.005, 0.001, 4,
                            systematic=(np.zeros((6, P)), np.zeros((2, 6, P)), Bc))
    assert g0.order[0] not in g2.order
    assert np.all(np.diff(g2.criterion) <= 1e-12)
    # every candidate carries more systematic error than it brings: fewer stops
    Bbad = rng.normal(0, 0.5, (2, 40, 6, P))
    g3, a3, G3 = pl.greedy_chain_systematic(
        Fb + np.eye(6) * 1e8, M, X, 0.005, 0.001, 4,
        systematic=(np.zeros((6, P)), np.zeros((2, 6, P)), Bbad))
    assert g3.order.size < 4 and np.all(np.diff(g3.criterion) <= 1e-12)
    assert G3.shape == (g3.order.size, 6, P)
    with pytest.raises(ValueError, match="systematic must be"):
        pl.greedy_chain(Fb, M, X, 0.005, 0.001, 2,
                        systematic=(np.zeros((6, P)), np.zeros((2, 6, P)), Bc[:, :10]))


def test_chain_information_reproduces_the_chosen_chain_and_checks_its_input():
    """The planner's model of any chain (batched) equals what the greedy choice weighed for
    the chain it chose — the same predicted 1-sigma after its stops, with and without the
    systematic errors — and bad chains are refused with what was received."""
    rng = np.random.default_rng(9)
    X = _X()
    Cb = _motions(rng, 30, max_angle=0.05)
    Fb = info.motion_information(Cb, g.invert_transform(X) @ Cb @ X, X, 0.005, 0.001).sum(0)
    M = _motions(rng, 40)
    P = 7
    sysm = (rng.normal(0, 1e-3, (6, P)), rng.normal(0, 1e-3, (2, 6, P)),
            rng.normal(0, 1e-3, (2, 40, 6, P)))
    scale = rng.uniform(0.5, 2.0, 40)
    for sy in (None, sysm):
        res, added, added_g = pl.greedy_chain_systematic(Fb, M, X, 0.005, 0.001, 4,
                                                         noise_scale=scale, systematic=sy)
        others = np.stack([rng.choice(40, 4, replace=False) for _ in range(3)])
        chains = np.concatenate([res.order[None], others])
        F, G = pl.chain_information(Fb, M, X, 0.005, 0.001, chains, noise_scale=scale,
                                    systematic=sy)
        assert F.shape == (4, 6, 6) and G.shape == (4, 6, 0 if sy is None else P)
        np.testing.assert_allclose(F[0], Fb + added.sum(0), rtol=1e-12, atol=1e-9)
        if sy is not None:
            np.testing.assert_allclose(G[0], sy[0] + added_g.sum(0), rtol=1e-12, atol=1e-15)
        # a chain's information does not depend on the other chains of the batch
        F1, _ = pl.chain_information(Fb, M, X, 0.005, 0.001, chains[2:3], noise_scale=scale,
                                     systematic=sy)
        np.testing.assert_allclose(F1[0], F[2], rtol=1e-12)
    for bad in (np.array([1, 2]), np.array([[0, 40]]), np.array([[0.0, 1.0]]),
                np.zeros((0, 3), int)):
        with pytest.raises(ValueError, match="chains must be"):
            pl.chain_information(Fb, M, X, 0.005, 0.001, bad)


def test_ranking_agreement_measures_how_well_predictions_rank_actual_errors():
    from simcalib.studies.advise.bounds import ranking_agreement
    rng = np.random.default_rng(2)
    n = 200
    std = rng.uniform(0.01, 1.0, (n, 6))
    size = np.sqrt(np.c_[(std[:, :3] ** 2).sum(1), (std[:, 3:] ** 2).sum(1)])
    exact = ranking_agreement(std, 3.0 * size)                 # actual = monotone in size
    assert exact["chains"] == n
    assert exact["spearman_rotation"] == pytest.approx(1.0)
    assert exact["spearman_translation"] == pytest.approx(1.0)
    assert exact["best_tenth_over_all_rotation"] < 0.6
    blind = ranking_agreement(std, rng.uniform(0, 1, (n, 2)))  # no relation
    assert abs(blind["spearman_rotation"]) < 0.2 and abs(blind["spearman_translation"]) < 0.2
    assert 0.7 < blind["best_tenth_over_all_translation"] < 1.3
    std[0, 4] = np.inf                                         # undetermined in one chain
    und = ranking_agreement(std, size)
    assert und["spearman_translation"] is None and und["spearman_rotation"] is not None
    # an axis no motion of the platform determines is left out of the predicted size
    std[:, 4] = np.inf
    skip = ranking_agreement(std, np.c_[size[:, 0], np.hypot(std[:, 3], std[:, 5])],
                             skip=("vy_m",))
    assert skip["spearman_translation"] == pytest.approx(1.0)
    few = ranking_agreement(std[1:6], size[1:6])
    assert few["spearman_rotation"] is None and few["best_tenth_over_all_rotation"] is None


def test_verification_chain_indices_follow_the_measured_stops():
    """A stop that was not measured is skipped: the chain links the measured ones and
    every datapoint index has a row in the combined basis."""
    from types import SimpleNamespace

    from simcalib.studies.advise.verification import _systematic_inputs
    D, P = 7, 3
    Ba, Bb = np.zeros((D, 6, P)), np.zeros((D, 6, P))
    pairs = np.stack([np.arange(D - 1), np.arange(1, D)], 1)
    base = SimpleNamespace(pose_error_basis=(Ba, Bb, pairs), truth=SimpleNamespace(world=None),
                           cfg=None, sources={})
    cand = SimpleNamespace(ref={"qpos": np.zeros(2), "mocap_pos": np.zeros((1, 3)),
                                "mocap_quat_wxyz": np.zeros((1, 4))},
                           qpos=np.zeros((5, 2)), mocap_pos=np.zeros((5, 1, 3)),
                           mocap_quat_wxyz=np.zeros((5, 1, 4)))
    frames = np.array([0, 1, 2, 4])              # stop 3 of 4 not measured
    st = SimpleNamespace(frame_index=frames, T_world_cam=np.tile(np.eye(4), (4, 1, 1)))
    out = _systematic_inputs(base, cand, np.arange(4), {"cam_a": st, "cam_b": st},
                             np.array([1, 2, 4]))
    pp = out["pose_pairs"]
    assert pp.shape == (D - 1 + 3, 2)
    np.testing.assert_array_equal(pp[D - 1:], [[D, D + 1], [D + 1, D + 2], [D + 2, D + 3]])
    assert out["pose_error_basis"][0].shape == (D + 4, 6, P) and pp.max() < D + 4


def _floor_problem(seed=11, n=10, P=4):
    rng = np.random.default_rng(seed)
    X = _X()
    Cb = _motions(rng, 30, max_angle=0.05)                   # nearly degenerate record
    Fb = info.motion_information(Cb, g.invert_transform(X) @ Cb @ X, X, 0.005, 0.001).sum(0)
    M = _motions(rng, n)
    sysm = (rng.normal(0, 1e-3, (6, P)), rng.normal(0, 1e-4, (2, 6, P)),
            rng.normal(0, 1e-4, (2, n, 6, P)))
    return Fb, M, X, sysm, rng.uniform(0.5, 2.0, n)


def test_expected_errors_are_the_root_of_each_blocks_variance():
    """Without systematic errors the expected error norms are the root sum of the squared
    per-axis 1-sigma of :func:`predicted_std`; shared errors only add to them."""
    Fb, M, X, sysm, scale = _floor_problem()
    chains = np.array([[0, 1, 2], [3, 4, 5]])
    F, G0 = pl.chain_information(Fb, M, X, 0.005, 0.001, chains, noise_scale=scale)
    e = pl.expected_errors(F, G0)
    for f, row in zip(F, e):
        s = info.predicted_std(f)
        np.testing.assert_allclose(row, [np.sqrt(np.sum(s[:3] ** 2)),
                                         np.sqrt(np.sum(s[3:] ** 2))], rtol=1e-5)
    F, G = pl.chain_information(Fb, M, X, 0.005, 0.001, chains, noise_scale=scale,
                                systematic=sysm)
    assert np.all(pl.expected_errors(F, G) > e)
    for bad in ((F[0], G), (F, G[:1]), (F, G[..., :3, :])):
        with pytest.raises(ValueError, match="F must be"):
            pl.expected_errors(*bad)


def test_best_expected_chains_settle_on_a_local_optimum_of_each_block():
    """The search's chain is what it reports (by :func:`chain_information`), no start ends
    worse than it began, no single stop exchange lowers the result (a local optimum), it
    is never below the brute-force minimum over every ordered chain, and from a start at
    that minimum it stays there."""
    import itertools
    Fb, M, X, sysm, scale = _floor_problem()
    n, k = M.shape[0], 2
    feasible = np.ones(n, bool)
    feasible[7] = False
    rng = np.random.default_rng(5)
    okidx = np.flatnonzero(feasible)
    starts = np.stack([rng.choice(okidx, k, replace=False) for _ in range(4)])
    every = np.array([c for c in itertools.permutations(okidx, k)])
    F, G = pl.chain_information(Fb, M, X, 0.005, 0.001, every, noise_scale=scale,
                                systematic=sysm)
    brute = pl.expected_errors(F, G)
    F, G = pl.chain_information(Fb, M, X, 0.005, 0.001, starts, noise_scale=scale,
                                systematic=sysm)
    start_vals = pl.expected_errors(F, G)
    kw = dict(feasible=feasible, noise_scale=scale, systematic=sysm)
    best = pl.best_expected_chains(Fb, M, X, 0.005, 0.001, starts, **kw)
    for b, (name, unit) in enumerate((("rotation", "deg"), ("translation", "m"))):
        res = best[name]
        chain = np.array(res["chain"])
        assert feasible[chain].all() and len(set(chain.tolist())) == k
        Fc, Gc = pl.chain_information(Fb, M, X, 0.005, 0.001, chain[None], noise_scale=scale,
                                      systematic=sysm)
        val = pl.expected_errors(Fc, Gc)[0, b]
        assert res[f"expected_{unit}"] == pytest.approx(val, rel=1e-9)
        assert res[f"expected_{unit}"] == pytest.approx(min(res[f"per_start_{unit}"]))
        assert np.all(np.array(res[f"per_start_{unit}"]) <= start_vals[:, b] * (1 + 1e-12))
        assert val >= brute[:, b].min() * (1 - 1e-12)
        for p in range(k):                                   # a local optimum
            trial = np.repeat(chain[None], okidx.size, 0)
            trial[:, p] = okidx
            trial = trial[[len(set(t.tolist())) == k for t in trial]]
            Ft, Gt = pl.chain_information(Fb, M, X, 0.005, 0.001, trial, noise_scale=scale,
                                          systematic=sysm)
            assert pl.expected_errors(Ft, Gt)[:, b].min() >= val * (1 - 1e-9)
        opt = every[int(np.argmin(brute[:, b]))]
        at_opt = pl.best_expected_chains(Fb, M, X, 0.005, 0.001, opt[None], **kw)[name]
        assert at_opt[f"expected_{unit}"] == pytest.approx(brute[:, b].min(), rel=1e-9)
    for bad in (np.array([[1, 1]]), np.array([[0, n]]), np.array([1, 2]),
                np.array([[0.0, 1.0]]), np.zeros((0, 2), int)):
        with pytest.raises(ValueError, match="starts must be"):
            pl.best_expected_chains(Fb, M, X, 0.005, 0.001, bad, **kw)
    with pytest.raises(ValueError, match="feasible must be"):
        pl.best_expected_chains(Fb, M, X, 0.005, 0.001, np.array([[7, 1]]), **kw)
