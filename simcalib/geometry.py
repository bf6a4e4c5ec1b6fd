"""Rigid-body geometry shared by every stage of simcalib.

Conventions (written once, used everywhere; see ``docs/conventions.md``):

* ``T_a_b`` is the pose of frame ``b`` expressed in frame ``a``: ``p_a = T_a_b @ p_b``.
  Homogeneous transforms are float64 arrays of shape ``(..., 4, 4)``.
* Quaternions are ``(x, y, z, w)`` (vector, scalar), as in the paper, scipy, rerun and
  TUM files. MuJoCo's ``(w, x, y, z)`` is converted at the MuJoCo boundary only, with
  :func:`quat_xyzw_from_wxyz` / :func:`quat_wxyz_from_xyzw`.
* A pose ``(R, t)`` is the unit dual quaternion ``q + eps q'`` with ``q = quat(R)`` and
  ``q' = 1/2 (t, 0) ⊗ q`` (paper eq. 2).
* ``q ⊗ p = L(q) p = R(p) q`` with the matrices of :func:`quat_left_matrix` and
  :func:`quat_right_matrix` (docs/conventions.md, checked).
* Metres and radians inside; degrees and centimetres only in reports.

Every function is pure and batched over leading axes; no Python loop per pose.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "adjoint_from_transform",
    "chordal_mean_rotation",
    "as_real_array",
    "project_points",
    "distort_pixels",
    "check_transforms",
    "check_rotation_matrices",
    "invert_transform",
    "matrix_from_euler_zyx",
    "skew_matrix",
    "transform_from_rotation_translation",
    "quat_from_matrix",
    "matrix_from_quat",
    "quat_multiply",
    "quat_conjugate",
    "quat_left_matrix",
    "quat_right_matrix",
    "quat_xyzw_from_wxyz",
    "quat_wxyz_from_xyzw",
    "matrix_from_rotvec",
    "rotvec_from_matrix",
    "dual_quat_from_transform",
    "transform_from_dual_quat",
    "relative_motions",
    "rotation_angle_rad",
    "rotation_error_rad",
    "translation_error_m",
    "random_rotation_matrices",
    "perturb_transforms",
]

ORTHONORMAL_TOL = 1e-6


# ----------------------------------------------------------------------------- checks
def check_transforms(T, name: str = "T", *, min_count: int | None = None,
                     tol: float = ORTHONORMAL_TOL) -> np.ndarray:
    """Validate an array of homogeneous rigid transforms and return it as float64.

    Raises ``ValueError`` naming ``name``, the received shape/value and what is allowed:
    shape must be ``(..., 4, 4)``, entries finite, rotation blocks orthonormal with
    determinant +1 (to ``tol``), bottom rows ``(0, 0, 0, 1)``.
    ``min_count`` (if given) requires ``(N, 4, 4)`` with ``N >= min_count``.
    """
    arr = as_real_array(T, name, "an array of 4x4 rigid transforms")
    if arr.ndim < 2 or arr.shape[-2:] != (4, 4):
        raise ValueError(f"{name} must have shape (..., 4, 4); received shape {arr.shape}")
    if min_count is not None:
        if arr.ndim != 3:
            raise ValueError(f"{name} must have shape (N, 4, 4); received shape {arr.shape}")
        if arr.shape[0] < min_count:
            raise ValueError(f"{name} needs at least {min_count} transforms; "
                             f"received {arr.shape[0]}")
    finite = np.isfinite(arr).all(axis=(-2, -1))
    if not finite.all():
        where = f" (first at index {_first_bad_index(finite)})" if arr.ndim > 2 else ""
        raise ValueError(f"{name} contains NaN or inf{where}; all entries must be finite")
    bottom = arr[..., 3, :]
    bottom_ok = np.all(np.abs(bottom - np.array([0.0, 0.0, 0.0, 1.0])) <= tol, axis=-1)
    if not bottom_ok.all():
        idx = _first_bad_index(bottom_ok)
        at = f"{name}[{idx}]" if arr.ndim > 2 else name
        raise ValueError(f"{at} has bottom row {np.asarray(bottom[idx]).tolist()}; "
                         "a rigid transform's bottom row must be (0, 0, 0, 1)")
    check_rotation_matrices(arr[..., :3, :3], name=f"{name} rotation block", tol=tol)
    return arr


def as_real_array(a, name: str, what: str = "a real array") -> np.ndarray:
    """``a`` as a float64 array; complex input (even with zero imaginary part) and
    non-numeric input raise TypeError naming ``name`` (no silent dropping of imaginary
    parts)."""
    try:
        raw = np.asarray(a)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be {what}; could not convert {type(a).__name__} "
                        f"({exc})") from None
    if np.iscomplexobj(raw):
        raise TypeError(f"{name} must be {what} with real entries; received complex dtype "
                        f"{raw.dtype}")
    try:
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be {what}; could not convert {type(a).__name__} to "
                        f"float64 ({exc})") from None


def check_rotation_matrices(R, name: str = "R", tol: float = ORTHONORMAL_TOL) -> np.ndarray:
    """Validate ``(..., 3, 3)`` rotation matrices (orthonormal, det +1)."""
    arr = as_real_array(R, name, "an array of 3x3 rotation matrices")
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have shape (..., 3, 3); received shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or inf; all entries must be finite")
    gram_err = np.abs(np.swapaxes(arr, -1, -2) @ arr - np.eye(3)).max(axis=(-2, -1))
    det = np.linalg.det(arr)
    ok = (gram_err <= tol) & (np.abs(det - 1.0) <= tol)
    if not ok.all():
        idx = _first_bad_index(ok)
        g_err = float(np.asarray(gram_err)[idx])
        d = float(np.asarray(det)[idx])
        why = (f"|R^T R - I|_max = {g_err:.3g}" if g_err > tol else
               f"det = {d:.15g} (|det - 1| = {abs(d - 1.0):.3g})")
        raise ValueError(
            f"{name}{f'[{idx}]' if np.ndim(det) else ''} is not a rotation: {why}; allowed: "
            "orthonormal with det +1 "
            f"(tolerance {tol:g}; |R^T R - I|_max = {g_err:.3g}, det = {d:.15g})")
    return arr


def _first_bad_index(ok: np.ndarray):
    bad = np.argwhere(~np.asarray(ok))
    if bad.size == 0:
        return ()
    return tuple(int(i) for i in bad[0]) if bad.shape[1] > 1 else int(bad[0, 0])


# ------------------------------------------------------------------------- transforms
def adjoint_from_transform(T: np.ndarray) -> np.ndarray:
    """``(..., 6, 6)`` adjoint of ``T`` ``(..., 4, 4)`` for twists ``xi = (omega, v)``:
    ``T exp(xi) T^-1 = exp(Ad_T xi)``, ``Ad_T = [[R, 0], [[p]x R, R]]``."""
    T = np.asarray(T, dtype=np.float64)
    R, p = T[..., :3, :3], T[..., :3, 3]
    A = np.zeros(T.shape[:-2] + (6, 6))
    A[..., :3, :3] = R
    A[..., 3:, 3:] = R
    A[..., 3:, :3] = skew_matrix(p) @ R
    return A


def skew_matrix(v: np.ndarray) -> np.ndarray:
    """``[v]x`` for ``(..., 3)`` vectors -> ``(..., 3, 3)`` (``[v]x @ w = v x w``)."""
    v = np.asarray(v, dtype=np.float64)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack([np.stack([o, -z, y], -1),
                     np.stack([z, o, -x], -1),
                     np.stack([-y, x, o], -1)], axis=-2)


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)`` (uses R^T, no general inverse)."""
    T = np.asarray(T, dtype=np.float64)
    R = T[..., :3, :3]
    t = T[..., :3, 3]
    out = np.zeros_like(T)
    Rt = np.swapaxes(R, -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, t)
    out[..., 3, 3] = 1.0
    return out


def transform_from_rotation_translation(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Stack ``(..., 3, 3)`` rotations and ``(..., 3)`` translations into ``(..., 4, 4)``."""
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    shape = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    out = np.zeros(shape + (4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = t
    out[..., 3, 3] = 1.0
    return out


def transforms_from_flat(mats, positions) -> np.ndarray:
    """``(N, 4, 4)`` transforms from ``N`` row-major rotation matrices flattened to 9 values
    (MuJoCo's ``xmat``, as recorded per step) and ``N`` translations."""
    return transform_from_rotation_translation(
        np.asarray(mats, dtype=np.float64).reshape(-1, 3, 3), positions)


# ------------------------------------------------------------------------ quaternions
def quat_xyzw_from_wxyz(q_wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo boundary: ``(w, x, y, z)`` -> ``(x, y, z, w)``."""
    q = np.asarray(q_wxyz, dtype=np.float64)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def quat_wxyz_from_xyzw(q_xyzw: np.ndarray) -> np.ndarray:
    """MuJoCo boundary: ``(x, y, z, w)`` -> ``(w, x, y, z)``."""
    q = np.asarray(q_xyzw, dtype=np.float64)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


#: per branch of :func:`quat_from_matrix` (the largest of 4x^2, 4y^2, 4z^2, 4w^2): where
#: each component's numerator sits in ``(s01, s02, s12, d21, d02, d10)`` (the branch's own
#: component, ``s / 4``, is written over its placeholder 0)
_QUAT_NUMERATOR = np.array([[0, 0, 1, 3], [0, 0, 2, 4], [1, 2, 0, 5], [3, 4, 5, 0]]).T


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(x, y, z, w)`` with ``w >= 0`` from rotations ``(..., 3, 3)``.

    Uses the numerically stable branch selection (largest diagonal term) per element,
    vectorised over contiguous rows of each entry, and divides only the chosen branch's
    numerators (the same operations on the same numbers as computing all four branches
    and picking one, a few times faster).
    """
    R = np.asarray(R, dtype=np.float64)[..., :3, :3]          # (a 4x4 transform's block)
    shape = R.shape[:-2]
    r = np.ascontiguousarray(np.reshape(R, (-1, 9)).T)          # (9, n): one row an entry
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = r
    # 4*x^2, 4*y^2, 4*z^2, 4*w^2 candidates
    diag = np.stack([1 + m00 - m11 - m22, 1 - m00 + m11 - m22,
                     1 - m00 - m11 + m22, 1 + m00 + m11 + m22])
    k = np.argmax(diag, axis=0)
    at = np.arange(k.size)
    s = 2.0 * np.sqrt(np.maximum(diag[k, at], 1e-300))
    num = np.stack([m01 + m10, m02 + m20, m12 + m21, m21 - m12, m02 - m20, m10 - m01])
    q = num[_QUAT_NUMERATOR[:, k], at] / s                       # (4, n)
    q[k, at] = 0.25 * s
    q = q / np.linalg.norm(q, axis=0)
    q = np.where(q[3] < 0, -q, q)
    return np.ascontiguousarray(q.T).reshape(shape + (4,))


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` from quaternions ``(x, y, z, w)`` (normalised first)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
    ], axis=-1)
    return R.reshape(q.shape[:-1] + (3, 3))


#: sign and component of each entry of L(q) (q ⊗ p = L(q) p) and R(p) (q ⊗ p = R(p) q),
#: components indexed (x, y, z, w) = (0, 1, 2, 3)
_L_INDEX = np.array([[3, 2, 1, 0], [2, 3, 0, 1], [1, 0, 3, 2], [0, 1, 2, 3]])
_L_SIGN = np.array([[1.0, -1.0, 1.0, 1.0], [1.0, 1.0, -1.0, 1.0],
                    [-1.0, 1.0, 1.0, 1.0], [-1.0, -1.0, -1.0, 1.0]])
_R_SIGN = np.array([[1.0, 1.0, -1.0, 1.0], [-1.0, 1.0, 1.0, 1.0],
                    [1.0, -1.0, 1.0, 1.0], [-1.0, -1.0, -1.0, 1.0]])


def quat_left_matrix(q: np.ndarray) -> np.ndarray:
    """``L(q)`` with ``q ⊗ p = L(q) p``; shape ``(..., 4, 4)``."""
    q = np.asarray(q, dtype=np.float64)
    return q[..., _L_INDEX] * _L_SIGN


def quat_right_matrix(p: np.ndarray) -> np.ndarray:
    """``R(p)`` with ``q ⊗ p = R(p) q``; shape ``(..., 4, 4)``."""
    p = np.asarray(p, dtype=np.float64)
    return p[..., _L_INDEX] * _R_SIGN


def quat_multiply(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Hamilton product ``q ⊗ p`` of ``(x, y, z, w)`` quaternions, batched."""
    return np.einsum("...ij,...j->...i", quat_left_matrix(q), np.asarray(p, dtype=np.float64))


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def matrix_from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vectors ``(..., 3)`` (radians) -> ``(..., 3, 3)``."""
    v = np.asarray(rotvec, dtype=np.float64)
    theta = np.linalg.norm(v, axis=-1)
    half = 0.5 * theta
    # sin(theta/2)/theta, stable near 0
    small = theta < 1e-8
    safe = np.where(small, 1.0, theta)
    k = np.where(small, 0.5 - theta**2 / 48.0, np.sin(half) / safe)
    q = np.concatenate([v * k[..., None], np.cos(half)[..., None]], axis=-1)
    return matrix_from_quat(q)


def matrix_from_euler_zyx(angles_rad: np.ndarray) -> np.ndarray:
    """``R = Rz(a) Ry(b) Rx(c)`` of angles ``(..., 3)`` = ``(a, b, c)`` (radians): turn by
    ``a`` about z, then ``b`` about the new y, then ``c`` about the newest x (intrinsic
    z-y'-x''; the same matrix as fixed-axis x-y-z turns by c, b, a). KUKA's A, B, C, Fanuc's
    R, P, W and ROS's yaw, pitch, roll (REP 103) are this ``(a, b, c)``."""
    a, b, c = np.moveaxis(np.asarray(angles_rad, dtype=np.float64), -1, 0)
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rows = [[ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc],
            [sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc],
            [-sb, cb * sc, cb * cc]]
    R = np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)
    return R


def rotvec_from_matrix(R: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` (radians, angle in [0, pi]) from ``(..., 3, 3)``."""
    q = quat_from_matrix(R)
    vec = q[..., :3]
    s = np.linalg.norm(vec, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 3])
    small = s < 1e-12
    scale = np.where(small, 2.0, angle / np.where(small, 1.0, s))
    return vec * scale[..., None]


# -------------------------------------------------------------------- dual quaternions
def dual_quat_from_transform(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit dual quaternions ``(q, q')`` of ``(..., 4, 4)`` transforms (paper eq. 2).

    ``q`` has ``w >= 0``; ``q' = 1/2 (t, 0) ⊗ q``.
    """
    T = np.asarray(T, dtype=np.float64)
    q = quat_from_matrix(T[..., :3, :3])
    t_quat = np.concatenate([T[..., :3, 3], np.zeros(T.shape[:-2] + (1,))], axis=-1)
    q_dual = 0.5 * quat_multiply(t_quat, q)
    return q, q_dual


def transform_from_dual_quat(q: np.ndarray, q_dual: np.ndarray) -> np.ndarray:
    """Transforms ``(..., 4, 4)`` from dual quaternions (``q`` is normalised first and
    ``q'`` is projected onto ``q · q' = 0``)."""
    q = np.asarray(q, dtype=np.float64)
    qd = np.asarray(q_dual, dtype=np.float64)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    q = q / norm
    qd = qd / norm
    qd = qd - np.sum(q * qd, axis=-1, keepdims=True) * q
    t = 2.0 * quat_multiply(qd, quat_conjugate(q))[..., :3]
    return transform_from_rotation_translation(matrix_from_quat(q), t)


# ------------------------------------------------------------------- relative motions
def relative_motions(T_w_a: np.ndarray, T_w_b: np.ndarray, i: np.ndarray, j: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Relative motions ``C_k = T_w_a[i_k]^-1 T_w_a[j_k]``, ``H_k = T_w_b[i_k]^-1 T_w_b[j_k]``.

    For two rigidly attached sensors a and b these satisfy ``C_k X = X H_k`` with
    ``X = T_a_b`` (docs/conventions.md). ``T_w_a`` and ``T_w_b`` may live in different world frames.
    """
    T_w_a = np.asarray(T_w_a, dtype=np.float64)
    T_w_b = np.asarray(T_w_b, dtype=np.float64)
    i = np.asarray(i)
    j = np.asarray(j)
    C = invert_transform(T_w_a[i]) @ T_w_a[j]
    H = invert_transform(T_w_b[i]) @ T_w_b[j]
    return C, H


def chordal_mean_rotation(R: np.ndarray) -> np.ndarray:
    """Chordal L2 mean ``(3, 3)`` of rotations ``(N, 3, 3)``: the rotation nearest (in
    Frobenius norm) to their arithmetic mean (SVD projection, ``det = +1``)."""
    R = np.asarray(R, dtype=np.float64)
    if R.ndim != 3 or R.shape[1:] != (3, 3) or R.shape[0] == 0:
        raise ValueError(f"R must be (N, 3, 3) with N >= 1; received shape {R.shape}")
    U, _, Vt = np.linalg.svd(R.mean(axis=0))
    if np.linalg.det(U @ Vt) < 0:
        U[:, -1] *= -1
    return U @ Vt


# ---------------------------------------------------------------------------- errors
def rotation_angle_rad(R: np.ndarray) -> np.ndarray:
    """Geodesic angle of rotations ``(..., 3, 3)`` in [0, pi], accurate near 0 and pi."""
    q = quat_from_matrix(R)
    return 2.0 * np.arctan2(np.linalg.norm(q[..., :3], axis=-1), np.abs(q[..., 3]))


def rotation_error_rad(T_est: np.ndarray, T_true: np.ndarray) -> np.ndarray:
    """Geodesic rotation error between transforms (or rotations) ``(..., 4|3, 4|3)``."""
    A = np.asarray(T_est, dtype=np.float64)[..., :3, :3]
    B = np.asarray(T_true, dtype=np.float64)[..., :3, :3]
    return rotation_angle_rad(np.swapaxes(A, -1, -2) @ B)


def translation_error_m(T_est: np.ndarray, T_true: np.ndarray) -> np.ndarray:
    """Euclidean distance between the translation parts of ``(..., 4, 4)`` transforms."""
    A = np.asarray(T_est, dtype=np.float64)
    B = np.asarray(T_true, dtype=np.float64)
    return np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)


# ------------------------------------------------------------------ random sampling
def random_rotation_matrices(rng: np.random.Generator, shape=()) -> np.ndarray:
    """Rotations uniform on SO(3) (normalised Gaussian quaternions), shape ``shape + (3, 3)``."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    shape = (shape,) if np.isscalar(shape) else tuple(shape)
    q = rng.standard_normal(shape + (4,))
    return matrix_from_quat(q)


def perturb_transforms(T: np.ndarray, sigma_r_rad: float, sigma_t_m: float,
                       rng: np.random.Generator) -> np.ndarray:
    """Paper eq. 38: ``T ∘ [δR | δt]`` with δR about an axis uniform on the sphere by an
    angle ~ N(0, σ_r²) and δt ~ N(0, σ_t² I). Batched over ``(..., 4, 4)``."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if not (np.isfinite(sigma_r_rad) and sigma_r_rad >= 0):
        raise ValueError(f"sigma_r must be finite and >= 0; received {sigma_r_rad}")
    if not (np.isfinite(sigma_t_m) and sigma_t_m >= 0):
        raise ValueError(f"sigma_t must be finite and >= 0; received {sigma_t_m}")
    T = np.asarray(T, dtype=np.float64)
    batch = T.shape[:-2]
    axis = rng.standard_normal(batch + (3,))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = rng.normal(0.0, sigma_r_rad, size=batch)
    dR = matrix_from_rotvec(axis * angle[..., None])
    dt = rng.normal(0.0, sigma_t_m, size=batch + (3,))
    return T @ transform_from_rotation_translation(dR, dt)


def project_points(T_cam_world: np.ndarray, p_world: np.ndarray, K: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Pinhole projection (OpenCV camera frame: z forward; no distortion), batched — the one
    projection of simcalib.

    ``T_cam_world`` ``(F, 4, 4)`` (world -> camera), ``p_world`` ``(..., 3)``, ``K``
    ``(3, 3)`` -> pixels ``(F, ..., 2)`` and depths ``(F, ...)``. Points at or behind the
    camera get finite but meaningless pixels: callers keep ``depth > 0``."""
    T = np.asarray(T_cam_world, dtype=np.float64)
    p = np.asarray(p_world, dtype=np.float64)
    K = np.asarray(K, dtype=np.float64)
    pc = np.einsum("fij,nj->fni", T[:, :3, :3], p.reshape(-1, 3)) + T[:, None, :3, 3]
    z = pc[..., 2]
    safe = np.where(np.abs(z) < 1e-12, 1e-12, z)
    uv = np.stack([K[0, 0] * pc[..., 0] / safe + K[0, 1] * pc[..., 1] / safe + K[0, 2],
                   K[1, 1] * pc[..., 1] / safe + K[1, 2]], axis=-1)
    lead = (T.shape[0],) + p.shape[:-1]
    return uv.reshape(lead + (2,)), z.reshape(lead)


def distort_pixels(uv: np.ndarray, K: np.ndarray, dist) -> tuple[np.ndarray, np.ndarray]:
    """Pinhole pixels ``(..., 2)`` -> the pixels a lens with distortion ``dist`` = (k1, k2,
    p1, p2, k3) (OpenCV's Brown-Conrady model, same ``K``) images them at, and ``(...)``
    bool: where the model is one-to-one (the radial map ``r (1 + k1 r^2 + k2 r^4 + k3 r^6)``
    still increasing at the point's normalised radius ``r``; beyond it a barrel model folds
    far-off points back into the image, which no lens does)."""
    d = np.asarray(dist, dtype=np.float64).ravel()
    if d.shape != (5,) or not np.all(np.isfinite(d)):
        raise ValueError(f"dist must be 5 finite numbers (k1, k2, p1, p2, k3); received {dist!r}")
    K = np.asarray(K, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    k1, k2, p1, p2, k3 = d
    x = (uv[..., 0] - K[0, 2] - K[0, 1] * (uv[..., 1] - K[1, 2]) / K[1, 1]) / K[0, 0]
    y = (uv[..., 1] - K[1, 2]) / K[1, 1]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    out = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=-1)
    valid = 1.0 + r2 * (3 * k1 + r2 * (5 * k2 + r2 * 7 * k3)) > 0
    return out, valid
