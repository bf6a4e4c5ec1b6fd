"""OpenCV's hand-eye solvers (``cv2.calibrateHandEye``) on simcalib's relative motions.

OpenCV takes absolute pose streams, not relative motions: ``R/t_gripper2base`` (poses
``Hg_k = T_base_gripper(k)``) and ``R/t_target2cam`` (``Hc_k = T_cam_target(k)``), and for
EVERY pair ``i < j`` it forms ``A_ij = Hg_j^-1 Hg_i`` and ``B_ij = Hc_j Hc_i^-1`` and solves
``A_ij X = X B_ij`` for ``X = T_gripper_cam`` (``cam2gripper``).

simcalib's problem is ``C_k X = X H_k`` (k = 1..N). We chain the motions into N+1 poses::

    Hg_0 = I,  Hg_k = Hg_{k-1} C_k^-1      =>  Hg_k^-1 Hg_{k-1} = C_k
    Hc_0 = I,  Hc_k = H_k Hc_{k-1}         =>  Hc_k Hc_{k-1}^-1 = H_k

so consecutive pairs reproduce exactly the given motions and OpenCV's ``cam2gripper`` is
our X. Note that OpenCV then uses all N(N+1)/2 pairs ``i < j``: besides the N given motions
it sees their products ``C_j ... C_{i+1}`` (and the matching H products). On noise-free data
these satisfy the same equation; with noise the products accumulate the noise of the chained
motions (a random walk), and motions that were not consecutive in time get paired too.
This is how OpenCV is used in practice, and it is what these wrappers measure.

OpenCV has no weighting parameter: ``uses_alpha=False``. The methods need
opencv-python-headless >= 4.10, < 5 (5.0 has no ``calibrateHandEye``; 4.9 and older had sign
bugs). ``cv2`` is imported lazily.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import invert_transform
from simcalib.solvers.problem import MotionProblem, SolverOutput
from simcalib.solvers.registry import register

__all__ = ["chain_motions_for_opencv", "opencv_hand_eye", "OPENCV_METHODS"]

# simcalib name -> cv2 constant name
OPENCV_METHODS = {
    "opencv_tsai": "CALIB_HAND_EYE_TSAI",
    "opencv_park": "CALIB_HAND_EYE_PARK",
    "opencv_horaud": "CALIB_HAND_EYE_HORAUD",
    "opencv_andreff": "CALIB_HAND_EYE_ANDREFF",
    "opencv_daniilidis": "CALIB_HAND_EYE_DANIILIDIS",
}


def _cv2():
    try:
        import cv2
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("the opencv_* solvers need opencv-python-headless>=4.10,<5 "
                          f"(import cv2 failed: {exc})") from None
    if not hasattr(cv2, "calibrateHandEye"):
        raise RuntimeError(
            f"OpenCV {cv2.__version__} has no cv2.calibrateHandEye (it was removed in "
            "OpenCV 5); install opencv-python-headless>=4.10,<5 to use the opencv_* solvers")
    return cv2


def chain_motions_for_opencv(C: np.ndarray, H: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Pose streams ``(Hg, Hc)``, each ``(N+1, 4, 4)``, whose consecutive OpenCV pairs are
    exactly ``C_k`` (gripper side) and ``H_k`` (camera side); see the module docstring."""
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    n = C.shape[0]
    C_inv = invert_transform(C)
    Hg = np.empty((n + 1, 4, 4))
    Hc = np.empty((n + 1, 4, 4))
    Hg[0] = np.eye(4)
    Hc[0] = np.eye(4)
    for k in range(n):  # a sequential chain: inherently one product per step
        Hg[k + 1] = Hg[k] @ C_inv[k]
        Hc[k + 1] = H[k] @ Hc[k]
    return Hg, Hc


def opencv_hand_eye(C: np.ndarray, H: np.ndarray, method: str = "opencv_daniilidis"
                    ) -> np.ndarray:
    """``X`` (4x4) with ``C_k X = X H_k`` from ``cv2.calibrateHandEye`` (``method`` one of
    :data:`OPENCV_METHODS`)."""
    if method not in OPENCV_METHODS:
        raise ValueError(f"unknown OpenCV hand-eye method {method!r}; available: "
                         f"{', '.join(OPENCV_METHODS)}")
    cv2 = _cv2()
    Hg, Hc = chain_motions_for_opencv(C, H)
    R, t = cv2.calibrateHandEye(
        [np.ascontiguousarray(m) for m in Hg[:, :3, :3]],
        [np.ascontiguousarray(m) for m in Hg[:, :3, 3:4]],
        [np.ascontiguousarray(m) for m in Hc[:, :3, :3]],
        [np.ascontiguousarray(m) for m in Hc[:, :3, 3:4]],
        method=getattr(cv2, OPENCV_METHODS[method]))
    X = np.eye(4)
    X[:3, :3] = np.asarray(R, dtype=np.float64)
    X[:3, 3] = np.asarray(t, dtype=np.float64).ravel()
    return X


def _make(name: str):
    def fn(problem: MotionProblem, alpha: float, prior, rng) -> SolverOutput:
        if prior is not None:
            raise ValueError(f"{name} does not support a prior; received prior={prior!r}")
        X = opencv_hand_eye(problem.C, problem.H, name)
        if not np.all(np.isfinite(X)):
            return SolverOutput(np.eye(4), {"opencv_method": OPENCV_METHODS[name]},
                                success=False,
                                message=f"cv2.calibrateHandEye ({OPENCV_METHODS[name]}) "
                                        "returned non-finite values (degenerate motions?)")
        if np.array_equal(X, np.eye(4)) and not np.allclose(problem.C, np.eye(4)):
            # OpenCV's failure return (it logs e.g. "Not enough informative motions")
            return SolverOutput(X, {"opencv_method": OPENCV_METHODS[name]}, success=False,
                                message=f"cv2.calibrateHandEye ({OPENCV_METHODS[name]}) "
                                        "failed and returned the identity (OpenCV: not "
                                        "enough informative motions; use more motions "
                                        "with larger rotations)")
        t_scale = float(max(np.abs(problem.C[:, :3, 3]).max(), np.abs(problem.H[:, :3, 3]).max()))
        t_norm = float(np.linalg.norm(X[:3, 3]))
        if t_norm > 1e3 * (1.0 + t_scale):
            return SolverOutput(X, {"opencv_method": OPENCV_METHODS[name]}, success=False,
                                message=f"cv2.calibrateHandEye ({OPENCV_METHODS[name]}) "
                                        f"returned an implausible translation |t| = "
                                        f"{t_norm:.3g} m for motions translating at most "
                                        f"{t_scale:.3g} m (degenerate motions?)")
        return SolverOutput(X, {"opencv_method": OPENCV_METHODS[name],
                                "opencv_pairs_used": problem.n * (problem.n + 1) // 2})
    fn.__name__ = f"_{name}"
    return fn


_DESCRIPTIONS = {
    "opencv_tsai": "OpenCV Tsai-Lenz 1989 (all i<j pairs of the chained poses)",
    "opencv_park": "OpenCV Park-Martin 1994 (all i<j pairs of the chained poses)",
    "opencv_horaud": "OpenCV Horaud-Dornaika 1995 (all i<j pairs of the chained poses)",
    "opencv_andreff": "OpenCV Andreff 1999 (all i<j pairs of the chained poses)",
    "opencv_daniilidis": "OpenCV Daniilidis 1999 (all i<j pairs of the chained poses)",
}

for _name in OPENCV_METHODS:
    register(_name, family="opencv", uses_alpha=False, supports_prior=False,
             expected_cost_us=40000.0, needs_rotation=True,
             description=_DESCRIPTIONS[_name])(_make(_name))
