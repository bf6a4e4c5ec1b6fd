"""Nonlinear least-squares hand-eye solvers (paper sec. 4): chvecopt, quatvecopt, dqnlopt,
dqnloptrnd.

All use ``scipy.optimize.least_squares`` (Levenberg-Marquardt, MINPACK) with analytic
Jacobians and tolerances near machine precision. The rotation is parametrised minimally
around a base rotation ``R0`` (quaternion ``q0``): ``R = R0 Exp(d)``, ``q = q0 ⊗ exp(d/2)``,
``d`` in R^3 (the Jacobian uses the right Jacobian ``J_r(d)`` of SO(3)); the translation
``T`` of X is free. After a solve the base is re-centred at the result and the solve is
repeated until the step ``|d|`` is tiny, so the chart never reaches its singularity
(|d| = 2 pi) and convergence is judged in a well-conditioned chart.

* ``chvecopt``  (eq. 30, first line): ``sum_i |R_Ci R - R R_Hi|_F^2
  + alpha^2 |(R_Ci - 1) T - R T_Hi + T_Ci|^2`` over (R, T).
* ``quatvecopt`` (eq. 30, second line): ``sum_i |q_Ci ⊗ q - q ⊗ q_Hi|^2 + alpha^2 |...|^2``
  (same translation term; sign-aligned quaternions).
  Both start from the better (lower own cost) of two candidates: the classic two-step
  estimate (rotation = smallest eigenvector of ``sum A_i^T A_i``, i.e. the rotation-only
  least squares, then the translation by linear least squares given R) and the ``dqopt``
  optimum of the paper's cost at the same alpha. Neither cost has a certificate; they are
  local optima near a good start.
* ``dqnlopt``: the paper's cost (8)/(9) (with the prior of eqs. 26-29 when given) on the
  manifold of unit dual quaternions (``q + eps q'`` with ``q' = 1/2 (T, 0) ⊗ q``, which
  satisfies both constraints identically), started at the ``dqopt`` solution. The 8N
  residuals are compressed to 8 through a square root of the 8x8 Gram matrix
  ``[[S, W], [W^T, M]]`` of :func:`simcalib.solvers.kernels.gram.problem_matrices` (a constant
  ``c |q|^2`` is added when the prior makes it indefinite; it does not move the minimiser).
* ``dqnloptrnd``: the same from ``n_starts`` random starts (rotation uniform on SO(3),
  translation ~ N(0, s^2 I) with s the RMS translation of the motions, at least 1 m), drawn
  from the rng passed in; the lowest cost wins. Default ``n_starts = 20``; other counts via
  :func:`dqnlopt_random_starts` or :func:`make_dqnloptrnd`.

``scipy.optimize`` is imported lazily.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import dual_quat_from_transform, matrix_from_quat, quat_from_matrix, \
    quat_left_matrix, quat_multiply, quat_right_matrix, random_rotation_matrices, \
    skew_matrix, transform_from_rotation_translation
from simcalib.solvers.kernels.gram import prior_penalty, problem_matrices
from simcalib.solvers.problem import MotionProblem, SolverOutput, problem_cost
from simcalib.solvers.registry import register

__all__ = ["chvecopt", "quatvecopt", "dqnlopt", "dqnlopt_random_starts", "make_dqnloptrnd",
           "chvec_cost", "quatvec_cost", "DEFAULT_RANDOM_STARTS"]

DEFAULT_RANDOM_STARTS = 20
_TOL = 1e-15          # least_squares ftol/xtol/gtol (MINPACK needs > machine eps)
_MAX_RECENTRE = 6     # re-centring passes
_RECENTRE_STEP = 1e-6  # stop re-centring when |d| of a pass is below this (radians)


# ------------------------------------------------------------------ SO(3) helpers


_GEN = skew_matrix(np.eye(3))  # (3, 3, 3): [e_k]x


def _exp_quat(d):
    """Quaternion (x, y, z, w) of Exp(d), d in R^3 (rotation vector)."""
    th = float(np.linalg.norm(d))
    if th < 1e-8:
        s = 0.5 - th * th / 48.0
        return np.array([s * d[0], s * d[1], s * d[2], 1.0 - th * th / 8.0])
    s = np.sin(0.5 * th) / th
    return np.array([s * d[0], s * d[1], s * d[2], np.cos(0.5 * th)])


def _right_jacobian(d):
    """J_r(d): Exp(d + e) = Exp(d) Exp(J_r(d) e) to first order."""
    th = float(np.linalg.norm(d))
    K = skew_matrix(d)
    if th < 1e-6:
        return np.eye(3) - 0.5 * K + K @ K / 6.0
    return (np.eye(3) - (1.0 - np.cos(th)) / th**2 * K
            + (th - np.sin(th)) / th**3 * K @ K)


def _rot_state(q0, d):
    """q, R and the Jacobians dq/dd (4x3) and the body rates w = J_r dd (3x3)."""
    q = quat_multiply(q0, _exp_quat(d))
    Jr = _right_jacobian(d)
    dq = 0.5 * quat_left_matrix(q)[:, :3] @ Jr
    return q, matrix_from_quat(q), dq, Jr


# --------------------------------------------------------------- generic driver
def _least_squares(fun_jac, x0):
    from scipy.optimize import least_squares
    cache = {}

    def f(x):
        r, J = fun_jac(x)
        cache["J"], cache["x"] = J, x.copy()
        return r

    def jac(x):
        if "x" in cache and np.array_equal(cache["x"], x):
            return cache["J"]
        return fun_jac(x)[1]

    return least_squares(f, x0, jac=jac, method="lm", xtol=_TOL, ftol=_TOL, gtol=_TOL,
                         max_nfev=400)


def _optimise(make_fun_jac, q0, T0):
    """Minimise over (d, T) with re-centring; returns (q, T, result, passes)."""
    q = np.asarray(q0, dtype=np.float64)
    T = np.asarray(T0, dtype=np.float64)
    nfev = 0
    for it in range(_MAX_RECENTRE):
        fun_jac = make_fun_jac(q)
        res = _least_squares(fun_jac, np.concatenate([np.zeros(3), T]))
        nfev += res.nfev
        d = res.x[:3]
        q = quat_multiply(q, _exp_quat(d))
        q = q / np.linalg.norm(q)
        T = res.x[3:]
        if np.linalg.norm(d) < _RECENTRE_STEP:
            break
    return q, T, res, {"nfev": nfev, "recentre_passes": it + 1, "status": int(res.status),
                       "lsq_message": res.message}


# --------------------------------------------------------------- eq. (30) costs
def _translation_parts(problem):
    RC = problem.C[:, :3, :3]
    TC = problem.C[:, :3, 3]
    TH = problem.H[:, :3, 3]
    return RC, TC, TH


def _trans_residual(problem, R, T, alpha):
    RC, TC, TH = _translation_parts(problem)
    return alpha * (np.einsum("nij,j->ni", RC, T) - T - TH @ R.T + TC)


def chvec_cost(X, problem: MotionProblem, alpha: float) -> float:
    """Eq. (30), first line (chordal rotation term + translation term) at X."""
    R, T = X[:3, :3], X[:3, 3]
    E = problem.C[:, :3, :3] @ R - R @ problem.H[:, :3, :3]
    return float(np.sum(E * E) + np.sum(_trans_residual(problem, R, T, alpha) ** 2))


def quatvec_cost(X, problem: MotionProblem, alpha: float) -> float:
    """Eq. (30), second line (quaternion rotation term + translation term) at X."""
    q = quat_from_matrix(X[:3, :3])
    A = quat_left_matrix(problem.q_C) - quat_right_matrix(problem.q_H)
    r = A @ q
    return float(np.sum(r * r)
                 + np.sum(_trans_residual(problem, X[:3, :3], X[:3, 3], alpha) ** 2))


def _vec_fun_jac_factory(problem, alpha, kind):
    RC, TC, TH = _translation_parts(problem)
    RH = problem.H[:, :3, :3]
    n = problem.n
    I3 = np.eye(3)
    A = quat_left_matrix(problem.q_C) - quat_right_matrix(problem.q_H)   # (n, 4, 4)

    def make(q0):
        def fun_jac(x):
            d, T = x[:3], x[3:]
            q, R, dq, Jr = _rot_state(q0, d)
            # translation residual and Jacobian
            rt = alpha * (np.einsum("nij,j->ni", RC, T) - T - TH @ R.T + TC)     # (n, 3)
            Jt_w = alpha * np.einsum("ij,njk->nik", R, skew_matrix(TH))               # (n, 3, 3)
            Jt_d = Jt_w @ Jr
            Jt_T = alpha * (RC - I3)
            if kind == "chvec":
                E = RC @ R - R @ RH                                              # (n, 3, 3)
                RG = np.einsum("ij,kjl->kil", R, _GEN)                           # (3k, 3, 3)
                dE = (np.einsum("nij,kjl->nkil", RC, RG)
                      - np.einsum("kij,njl->nkil", RG, RH))                      # (n, k, 3, 3)
                Jr_w = dE.reshape(n, 3, 9).transpose(0, 2, 1)                    # (n, 9, 3)
                Jr_d = Jr_w @ Jr
                rr = E.reshape(n, 9)
                nr = 9
            else:
                rr = A @ q                                                       # (n, 4)
                Jr_d = A @ dq                                                    # (n, 4, 3)
                nr = 4
            r = np.concatenate([rr, rt], axis=1).ravel()
            J = np.zeros((n, nr + 3, 6))
            J[:, :nr, :3] = Jr_d
            J[:, nr:, :3] = Jt_d
            J[:, nr:, 3:] = Jt_T
            return r, J.reshape(n * (nr + 3), 6)
        return fun_jac
    return make


def _two_step_start(problem):
    """Rotation-only least squares (smallest eigenvector of sum A^T A), then T by linear
    least squares given R."""
    A = quat_left_matrix(problem.q_C) - quat_right_matrix(problem.q_H)
    _, V = np.linalg.eigh(np.einsum("nki,nkj->ij", A, A))
    q = V[:, 0] * (1.0 if V[3, 0] >= 0 else -1.0)
    R = matrix_from_quat(q)
    RC, TC, TH = _translation_parts(problem)
    lhs = (RC - np.eye(3)).reshape(-1, 3)
    rhs = (TH @ R.T - TC).reshape(-1)
    T = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    return transform_from_rotation_translation(R, T)


def _dqopt_start(problem, alpha, prior=None, rng=None):
    from simcalib.solvers.dq import solve_dq
    out = solve_dq("dqopt", problem, alpha, prior)
    X = np.asarray(out.X, dtype=np.float64)
    if not out.success or X.shape != (4, 4) or not np.isfinite(X).all():
        raise ValueError(f"dqopt returned no valid transform ({out.message or 'non-finite'})")
    return X


def _optimal_start(problem, alpha, prior, rng):
    """The dqopt solution; if dqopt fails on this input, the dqoptpoly one (same optimum,
    independent route). Returns (X, name)."""
    try:
        return _dqopt_start(problem, alpha, prior, rng), "dqopt"
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        from simcalib.solvers.dqpoly import dqoptpoly
        return dqoptpoly(problem, alpha, prior).X, f"dqoptpoly (dqopt failed: {exc})"


def _vec_solve(problem, alpha, kind, rng):
    cost_fn = chvec_cost if kind == "chvec" else quatvec_cost
    starts = {"two_step": _two_step_start(problem)}
    try:
        starts["dqopt"] = _dqopt_start(problem, alpha, None, rng)
    except (ValueError, RuntimeError, np.linalg.LinAlgError):
        pass
    start_costs = {k: cost_fn(v, problem, alpha) for k, v in starts.items()}
    name = min(start_costs, key=start_costs.get)
    X0 = starts[name]
    q, T, res, info = _optimise(_vec_fun_jac_factory(problem, alpha, kind),
                                quat_from_matrix(X0[:3, :3]), X0[:3, 3])
    X = transform_from_rotation_translation(matrix_from_quat(q), T)
    final = cost_fn(X, problem, alpha)
    diag = dict(info, start=name, start_costs=start_costs, own_cost=final)
    return SolverOutput(X, diag, success=bool(res.status > 0),
                        message=f"least_squares from the {name} start: {res.message}")


def chvecopt(problem: MotionProblem, alpha: float = 1.0, rng=None) -> SolverOutput:
    """Minimise eq. (30) (chordal rotation term) by Levenberg-Marquardt."""
    return _vec_solve(problem, alpha, "chvec", rng)


def quatvecopt(problem: MotionProblem, alpha: float = 1.0, rng=None) -> SolverOutput:
    """Minimise eq. (30) (quaternion rotation term) by Levenberg-Marquardt."""
    return _vec_solve(problem, alpha, "quatvec", rng)


# --------------------------------------------------------------- DQ cost (8)/(9)
def _gram_sqrt(problem, alpha, prior):
    """``U`` (8x8) with ``z^T U^T U z = z^T G z + c |q|^2``, G = [[S, W], [W^T, M]]
    (c >= 0 only when the prior makes G indefinite)."""
    S, W, M = problem_matrices(problem, alpha, prior)
    G = np.block([[S, W], [W.T, M]])
    G = 0.5 * (G + G.T)
    e, V = np.linalg.eigh(G)
    shift = 0.0
    if e[0] < -1e-13 * max(abs(e[-1]), 1e-300):
        # constant c |q|^2 (= c on |q| = 1) making G PSD: c = -lambda_min(Schur complement)
        Minv = np.linalg.inv(M)
        Z0 = S - W @ Minv @ W.T
        shift = max(0.0, -float(np.linalg.eigvalsh(0.5 * (Z0 + Z0.T))[0])) * (1 + 1e-12)
        G[:4, :4] += shift * np.eye(4)
        e, V = np.linalg.eigh(G)
    U = np.sqrt(np.clip(e, 0.0, None))[:, None] * V.T
    return U, shift


def _dq_fun_jac_factory(U):
    def make(q0):
        def fun_jac(x):
            d, T = x[:3], x[3:]
            q, _, dq, _ = _rot_state(q0, d)
            Lt = quat_left_matrix(np.array([T[0], T[1], T[2], 0.0]))
            qd = 0.5 * Lt @ q
            z = np.concatenate([q, qd])
            dz = np.zeros((8, 6))
            dz[:4, :3] = dq
            dz[4:, :3] = 0.5 * Lt @ dq
            dz[4:, 3:] = 0.5 * quat_right_matrix(q)[:, :3]
            return U @ z, U @ dz
        return fun_jac
    return make


def _dq_from_X(X):
    q, qd = dual_quat_from_transform(X)
    return q, X[:3, 3]


def _objective(problem, alpha, prior, q, T):
    """Cost (8) plus the prior terms, from the full residuals (accurate to rounding; the
    8-residual Gram form used inside the optimiser is only ~1e-11 relative)."""
    X = transform_from_rotation_translation(matrix_from_quat(q), T)
    qq, qd = dual_quat_from_transform(X)
    cost = problem_cost(problem, qq, qd, alpha)
    return cost + (prior_penalty(qq, qd, prior) if prior is not None else 0.0)


def dqnlopt(problem: MotionProblem, alpha: float = 1.0, prior=None, rng=None,
            X0: np.ndarray | None = None) -> SolverOutput:
    """Minimise the paper's cost (8) (+ prior) by Levenberg-Marquardt on SE(3), from ``X0``
    (default: the ``dqopt`` solution)."""
    U, shift = _gram_sqrt(problem, alpha, prior)
    start = "given X0"
    if X0 is None:
        X0, start = _optimal_start(problem, alpha, prior, rng)
    q0, T0 = _dq_from_X(np.asarray(X0, dtype=np.float64))
    start_cost = _objective(problem, alpha, prior, q0, T0)
    q, T, res, info = _optimise(_dq_fun_jac_factory(U), q0, T0)
    X = transform_from_rotation_translation(matrix_from_quat(q), T)
    diag = dict(info, start=start, start_objective=start_cost,
                objective=_objective(problem, alpha, prior, q, T))
    return SolverOutput(X, diag, success=bool(res.status > 0),
                        message=f"least_squares from the {start} solution: {res.message}")


def dqnlopt_random_starts(problem: MotionProblem, alpha: float = 1.0, prior=None,
                          rng: np.random.Generator | None = None,
                          n_starts: int = DEFAULT_RANDOM_STARTS) -> SolverOutput:
    """``dqnlopt`` from ``n_starts`` random starts drawn from ``rng``; the lowest cost wins.
    Diagnostics list every start's final objective."""
    if isinstance(n_starts, bool) or not isinstance(n_starts, (int, np.integer)) \
            or n_starts < 1:
        raise ValueError(f"n_starts must be an integer >= 1; received {n_starts!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError("dqnloptrnd needs a numpy.random.Generator for its random starts; "
                        f"received {type(rng).__name__}")
    U, shift = _gram_sqrt(problem, alpha, prior)
    t_all = np.concatenate([problem.C[:, :3, 3], problem.H[:, :3, 3]])
    scale = max(1.0, float(np.sqrt(np.mean(np.sum(t_all**2, axis=1)))))
    Rs = random_rotation_matrices(rng, (int(n_starts),))
    Ts = rng.normal(0.0, scale, size=(int(n_starts), 3))
    best = None
    objectives = np.empty(int(n_starts))
    nfev = 0
    for k in range(int(n_starts)):
        q, T, res, info = _optimise(_dq_fun_jac_factory(U), quat_from_matrix(Rs[k]), Ts[k])
        objectives[k] = _objective(problem, alpha, prior, q, T)
        nfev += info["nfev"]
        if best is None or objectives[k] < best[0]:
            best = (objectives[k], q, T, res)
    _, q, T, res = best
    X = transform_from_rotation_translation(matrix_from_quat(q), T)
    span = objectives.max() - objectives.min()
    tol = 1e-9 * max(abs(objectives.min()), 1e-300)
    n_at_best = int(np.sum(objectives - objectives.min() <= tol))
    diag = {"n_starts": int(n_starts), "start_objectives": objectives, "nfev": nfev,
            "n_starts_at_best": n_at_best, "objective_spread": float(span),
            "translation_scale_m": scale}
    return SolverOutput(X, diag, success=True,
                        message=f"best of {n_starts} random starts ({n_at_best} reached it)")


def make_dqnloptrnd(n_starts: int):
    """A solver function (registry signature) running ``n_starts`` random starts."""
    def fn(problem, alpha, prior, rng):
        return dqnlopt_random_starts(problem, alpha, prior, rng, n_starts=n_starts)
    fn.__name__ = f"dqnloptrnd_{n_starts}"
    return fn


# ------------------------------------------------------------------ registration
@register("chvecopt", family="dq-nonlinear", uses_alpha=True, supports_prior=False,
          slow=True, expected_cost_us=40000.0,
          description="eq. 30 chordal-rotation + translation cost, Levenberg-Marquardt")
def _chvecopt(problem, alpha, prior, rng):
    return chvecopt(problem, alpha, rng)


@register("quatvecopt", family="dq-nonlinear", uses_alpha=True, supports_prior=False,
          slow=True, expected_cost_us=8000.0,
          description="eq. 30 quaternion-rotation + translation cost, Levenberg-Marquardt")
def _quatvecopt(problem, alpha, prior, rng):
    return quatvecopt(problem, alpha, rng)


@register("dqnlopt", family="dq-nonlinear", uses_alpha=True, supports_prior=True,
          slow=True, expected_cost_us=8000.0, supports_weights=True,
          description="paper cost (8) by Levenberg-Marquardt on SE(3) from the dqopt solution")
def _dqnlopt(problem, alpha, prior, rng):
    return dqnlopt(problem, alpha, prior, rng)


register("dqnloptrnd", family="dq-nonlinear", uses_alpha=True, supports_prior=True,
         stochastic=True, n_starts=DEFAULT_RANDOM_STARTS, slow=True,
         expected_cost_us=40000.0, supports_weights=True,
         description=f"paper cost (8) by Levenberg-Marquardt from {DEFAULT_RANDOM_STARTS} "
                     "random starts (rng), best kept")(make_dqnloptrnd(DEFAULT_RANDOM_STARTS))
