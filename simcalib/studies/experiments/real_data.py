"""Real-data regression table (recordings `calibrate` has never seen).

Every public recording of ``../shared/data/real`` (18 folders, TUM ``a.txt`` / ``b.txt``)
and of ``../shared/data/eth`` (5 zips of ETH hand_eye_calibration CSV files) is one entry of
:data:`SETS`: its files, its reference ``X = T_a_b`` (or none), the tolerance its README
calls "correct", the directions a correct verdict must flag, and the reference's own spread
where one is stated. :func:`run_set` calibrates one set with the ``calibrate`` DEFAULTS
through the library (``a``, ``b``, ``output`` in a temporary folder, ``recording=false``,
nothing else) and returns a :class:`SetResult`; :func:`main` writes the markdown table
(``docs/real-data.md``)::

    python -m simcalib.studies.experiments.real_data [--output docs/real-data.md] [--sets NAME ...]
    python -m simcalib experiment real_data [sets=[NAME,...]] [output=DIR]

Data folders: ``$SIMCALIB_REAL_DIR`` / ``$SIMCALIB_ETH_DIR``, default
``<repo>/../shared/data/real`` and ``.../eth``. The ETH zips are unpacked into a cache
folder (default ``<tmp>/simcalib_eth_cache``), never into the repository.

Error convention: :func:`simcalib.solvers.diagnostics.uncertainty.pose_error`
``(X_ref, X_est)`` (rotation vector of ``R_ref R_est^T``, ``t_ref - t_est``, frame a),
the convention the reported covariance refers to. NEES: :func:`nees` (pseudo-inverse on the
axes whose reported variance is finite, restricted to the components the reference pins).
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import re
import sys
import tempfile
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.errors import DataError
from simcalib.studies.experiments import experiment

__all__ = ["RequiredFlag", "Tolerance", "RealSet", "Reference", "FlaggedDirection", "Nees",
           "MethodResult", "SetResult", "Agreement", "Summary", "SETS", "CROSS_SET_PAIRS",
           "LOOPS", "DATA_NOTES", "REAL_ENV", "ETH_ENV", "OPENCV_MAX_POSES",
           "NEES_TARGET_SHARE", "AGREEMENT_SIGMA", "ALL_AXES", "ROTATION_ONLY", "real_dir",
           "eth_dir", "set_by_name", "set_available", "set_paths", "read_reference_file",
           "read_readme_reference", "read_tum", "load_reference", "reference_tolerance",
           "nees", "chi2_bound_95", "subsample_indices", "opencv_estimates", "run_set",
           "run_sets", "tolerance_check", "method_within_tolerance", "flag_check",
           "agreement", "loop_agreement", "propagate_covariance", "summarise", "markdown",
           "write_document",
           "RealDataConfig", "run", "main"]

REAL_ENV = "SIMCALIB_REAL_DIR"
ETH_ENV = "SIMCALIB_ETH_DIR"
#: the most synchronised poses handed to cv2.calibrateHandEye (it builds all i<j pairs)
OPENCV_MAX_POSES = 150
#: the share of referenced sets whose NEES (with the reference's own accuracy) must be
#: within its 95 % bound
NEES_TARGET_SHARE = 0.8
#: cross-set agreement: every axis of the difference within this many combined sigma
AGREEMENT_SIGMA = 3.0
ALL_AXES = (True,) * 6
ROTATION_ONLY = (True, True, True, False, False, False)


# ----------------------------------------------------------------------------- the table
@dataclass(frozen=True)
class RequiredFlag:
    """A direction a correct verdict must list (``Direction`` of the solution's
    uncertainty): ``kind`` ``translation`` or ``rotation``, ``axis_a`` (frame a), accepted
    ``reasons``; matched when the flagged direction's translation (rotation) part is within
    ``acos(min_cos)`` of the axis."""
    kind: str
    axis_a: tuple
    reasons: tuple = ("undetermined",)
    text: str = ""
    min_cos: float = 0.9


@dataclass(frozen=True)
class Tolerance:
    """"Correct" from the set's README. ``translation_axes``: the reference translation's
    valid components (scara: z invalid); ``waive_translation_if_flagged``: a flagged
    translation direction is an honest alternative to an accurate translation;
    ``offset_s`` / ``offset_tolerance_s``: the clock offset ``t_b - t_a`` expected."""
    rotation_deg: float | None
    translation_m: float | None
    text: str
    translation_axes: tuple = (True, True, True)
    waive_translation_if_flagged: bool = False
    offset_s: float | None = None
    offset_tolerance_s: float | None = None


@dataclass(frozen=True)
class RealSet:
    """One recording. ``source``: ``real`` (folder ``folder`` of the real dir) or ``eth``
    (``folder`` = zip file name, ``file_a`` / ``file_b`` = members). ``reference``:
    ``file`` (reference_X_T_a_b.txt), ``readme`` (numbers in README.md), ``identity``,
    ``opencv`` (OpenCV PARK on the files' stamp-matched pairs: the README's "correct" is
    relative to the OpenCV estimates; the same data, so not counted for the NEES target) or
    None. ``nees_axes``: the error components the reference pins (wx, wy, wz, vx, vy, vz)."""
    name: str
    source: str
    folder: str
    file_a: str
    file_b: str
    what: str
    reference: str | None = None
    tolerance: Tolerance | None = None
    required_flags: tuple = ()
    nees_axes: tuple = ALL_AXES
    notes: str = ""

    @property
    def independent_reference(self) -> bool:
        """A reference not computed from these same files (counts for the NEES target)."""
        return self.reference in ("file", "readme", "identity")


def _crwhe(tag: int, cam: int) -> RealSet:
    return RealSet(
        f"crwhe_tag{tag}_cam{cam}", "real", f"crwhe_tag{tag}_cam{cam}", "a.txt", "b.txt",
        f"tag {tag} / camera {cam} pose pairs (A_i X = Y B_i)", "file",
        Tolerance(None, None, "within the spread of the leave-one-camera-out reference "
                  "(its header's max member deviation)"),
        notes="reference: OpenCV PARK on the same tag seen by the other cameras")


_KUKA_TOL = Tolerance(0.2, 0.002, "within ~0.2 deg / ~2 mm of the OpenCV estimates")
_STHE_TOL = Tolerance(0.5, 0.005, "within ~0.5 deg / ~5 mm of the OpenCV estimates")
_HAND_Z = RequiredFlag("translation", (0.0, 0.0, 1.0), ("undetermined", "poorly determined"),
                       "translation along hand z flagged (not determined)")
_CAM_Y = RequiredFlag("translation", (0.0, 1.0, 0.0), ("undetermined", "poorly determined"),
                      "translation along cam0 y (vertical) flagged")

SETS: tuple = (
    *(_crwhe(t, c) for t, c in ((0, 0), (0, 1), (14, 7), (15, 0), (15, 1), (20, 6), (22, 2))),
    RealSet("euroc_v102", "real", "euroc_v102", "a.txt", "b.txt",
            "EuRoC V1_02 Vicon ground truth vs a VIO estimate", "identity",
            Tolerance(0.5, 0.05, "within ~0.5 deg / few cm of identity (translation weak)"),
            nees_axes=ROTATION_ONLY,
            notes="identity assumed; the translation reference is weak (NEES on rotation)"),
    RealSet("kitti00_orb", "real", "kitti00_orb", "a.txt", "b.txt",
            "KITTI 00 GPS/INS ground truth vs ORB-SLAM", "identity",
            Tolerance(0.5, None, "rotation within ~0.5 deg and the y translation flagged"),
            (_CAM_Y,), ROTATION_ONLY,
            notes="x/z translation carries ORB-SLAM scale / drift: not part of 'correct'"),
    *(RealSet(f"rwhecalib_kuka_{k}", "real", f"rwhecalib_kuka_{k}", "a.txt", "b.txt",
              "KUKA arm + camera (board poses from the images)", "opencv", _KUKA_TOL)
      for k in (1, 2, 3)),
    RealSet("scara_handeye4dof", "real", "scara_handeye4dof", "a.txt", "b.txt",
            "SCARA robot + camera (all rotations about the base z)", "readme",
            Tolerance(2.0, 0.05, "rotation within ~1-2 deg, x/y translation within a few cm; "
                      "hand z flagged undetermined", translation_axes=(True, True, False)),
            (_HAND_Z,), (True, True, True, True, True, False),
            notes="reference manually measured; its z translation is invalid"),
    *(RealSet(f"sthe_calib_{s}", "real", f"sthe_calib_{s}", "a.txt", "b.txt",
              "robot + wrist camera (chessboard poses from the images)", "opencv", _STHE_TOL)
      for s in ("a", "b")),
    RealSet("tabb_rwhe_dataset1", "real", "tabb_rwhe_dataset1", "a.txt", "b.txt",
            "Tabb RWHE dataset 1, robot + chessboard camera", "file",
            Tolerance(1.0, 0.05, "within 1 deg / 50 mm of Tabb's rwhe_AA_RPI (OpenCV's test)"),
            notes="reference is another method's estimate"),
    RealSet("tum_fr1_xyz_rgbdslam", "real", "tum_fr1_xyz_rgbdslam", "a.txt", "b.txt",
            "TUM fr1/xyz motion capture vs RGBD-SLAM", "identity",
            Tolerance(2.0, 0.02, "within ~1-2 deg / ~2 cm; translation either accurate or "
                      "flagged", waive_translation_if_flagged=True)),
    RealSet("tum_fr2_desk_orb", "real", "tum_fr2_desk_orb", "a.txt", "b.txt",
            "TUM fr2/desk motion capture vs ORB-SLAM", "identity",
            Tolerance(1.0, 0.02, "within ~1 deg / ~2 cm of identity; offset near 0",
                      offset_s=0.0, offset_tolerance_s=0.05)),
    # ---- ETH hand_eye_calibration (zips): no published X
    RealSet("eth_robot_arm_sim", "eth", "robot_arm_w_color_camera_sim.zip",
            "robot_arm_sim_hand.csv", "robot_arm_sim_camera.csv",
            "simulated arm: hand vs camera-from-target"),
    RealSet("eth_prime_sense_1", "eth", "prime_sense_color_w_vicon_1.zip",
            "2017-04-09-18-13-10_vicon_prime_sense.csv",
            "2017-04-09-18-13-10_W_camera_rgb_image_raw.csv", "Vicon body vs PrimeSense camera",
            tolerance=Tolerance(None, None, "offset ~ -24 ms (tests/test_commands_calibrate.py)",
                                offset_s=-0.024, offset_tolerance_s=0.01)),
    RealSet("eth_robot_arm_real", "eth", "robot_arm_w_color_camera_real.zip",
            "robot_arm_complete_bag_color_and_ir_base_link_sr300_hinge.csv",
            "robot_arm_complete_bag_color_and_ir_target_ir.csv",
            "real arm: base_link->sr300 hinge vs IR camera from the target",
            notes="clocks not synchronised; the angular speeds correlate weakly at every lag "
                  "(best r = 0.23 at -33.7 s): no offset expected"),
    *(RealSet(f"eth_tango_{na.lower()}_{nb.lower()}", "eth", "tango_triplet_easy.zip",
              f"{na}_{fa}.csv", f"{nb}_{fb}.csv", f"Tango rig: {na} vs {nb} (one rig)",
              tolerance=Tolerance(None, None, "offset from the angular-speed cross-correlation "
                                  f"of the raw files (r = {r:.2f}; the three pairs close to 5 ms)",
                                  offset_s=off, offset_tolerance_s=0.05),
              notes="the three devices record at once on clocks ~2 min apart")
      for (na, fa), (nb, fb), off, r in (
          (("CALIGULA", "2017-04-06-18-21-33"), ("MARS", "2017-04-06-18-23-37"), 126.835, 0.99),
          (("MARS", "2017-04-06-18-23-37"), ("NERO", "2017-04-06-18-25-25"), 107.735, 0.99),
          (("CALIGULA", "2017-04-06-18-21-33"), ("NERO", "2017-04-06-18-25-25"), 234.575, 0.99))),
    RealSet("eth_falcon_vicon_odom", "eth", "5_falcon.zip",
            "5_falcon_merged_vicon_falcon-2017-04-07-12-36-38.csv",
            "5_falcon_merged_odom_imu-2017-04-07-12-36-38.csv", "drone: Vicon body vs odometry",
            tolerance=Tolerance(None, None, "offset from the angular-speed cross-correlation of "
                                "the raw files (r = 0.93)", offset_s=-0.46,
                                offset_tolerance_s=0.1),
            notes="camera streams W_r / color_imu / W_e are sparse; odom_imu correlates best"),
)

#: facts about the recordings found while building the table (not results of simcalib)
DATA_NOTES = (
    "ETH pairs: robot_arm_sim_hand + robot_arm_sim_camera; *_vicon_prime_sense + "
    "*_W_camera_rgb_image_raw; robot_arm real base_link_sr300_hinge + target_ir; the three "
    "Tango devices pairwise; 5_falcon vicon_falcon + odom_imu (*_falcon_vicon / *_imu_odom "
    "hold exactly the inverses of those poses, same stamps; W_r, W_d, W_e, color_imu, "
    "fisheye_imu are sparse, irregular camera tracks that correlate weakly with the Vicon "
    "body).",
    "Clock offsets t_b - t_a from the angular speed of the raw files (10 ms grid, "
    "cross-correlation): Tango CALIGULA->MARS +126.835 s, MARS->NERO +107.735 s, "
    "CALIGULA->NERO +234.575 s (r = 0.99; the loop closes within 5 ms): the three devices "
    "record the same motion at once, each on its own clock, ~2 minutes apart, so their "
    "stamp ranges do not overlap at offset 0; falcon Vicon->odom_imu -0.46 s (r = 0.93); "
    "PrimeSense -0.03 s (r = 0.49); the real robot arm has no clear peak (best r = 0.23).",
    "The crwhe, kuka, sthe, tabb and scara stamps are row / sample indices (synchronous "
    "pairs; the sthe sample numbers have gaps, e.g. 6 -> 8 -> 9): no offset exists to estimate.",
    "tum_*/a.txt start with the benchmark's 3 comment lines, the third a header naming "
    "the 8 columns after its '#' ('# timestamp tx ty tz qx qy qz qw').",
)

#: sets that appear to share one mount (README): their X must agree within the sigma
CROSS_SET_PAIRS = (("rwhecalib_kuka_1", "rwhecalib_kuka_3"), ("sthe_calib_a", "sthe_calib_b"))
#: how well the READMEs say the two mounts agree ("appear to share the camera mount": OpenCV
#: PARK gives the same X to this), read like a tolerance: the 95 % bound of the mounts'
#: own difference (deg, m)
STATED_AGREEMENT = {("rwhecalib_kuka_1", "rwhecalib_kuka_3"): (0.1, 0.006),
                    ("sthe_calib_a", "sthe_calib_b"): (0.3, 0.005)}
#: X_ac must equal X_ab X_bc (three streams of one rig)
LOOPS = (("eth_tango_caligula_mars", "eth_tango_mars_nero", "eth_tango_caligula_nero"),)


def set_by_name(name: str) -> RealSet:
    for s in SETS:
        if s.name == name:
            return s
    from simcalib.errors import unknown_choice
    raise unknown_choice("real data set", name, [s.name for s in SETS])


# ----------------------------------------------------------------------------- the data
def _repo_root() -> Path:
    return Path(__file__).resolve().parents[3]          # simcalib/studies/experiments/ -> repo


def real_dir() -> Path:
    return Path(os.environ.get(REAL_ENV, _repo_root() / ".." / "shared" / "data" / "real"))


def eth_dir() -> Path:
    return Path(os.environ.get(ETH_ENV, _repo_root() / ".." / "shared" / "data" / "eth"))


def _default_cache() -> Path:
    return Path(tempfile.gettempdir()) / "simcalib_eth_cache"


def set_available(entry: RealSet) -> tuple[bool, str]:
    """``(True, "")`` when the set's files are present, else ``(False, reason)``."""
    if entry.source == "real":
        d = real_dir() / entry.folder
        ok = (d / entry.file_a).is_file() and (d / entry.file_b).is_file()
        return ok, "" if ok else f"{d} not found (set {REAL_ENV})"
    z = eth_dir() / entry.folder
    return z.is_file(), "" if z.is_file() else f"{z} not found (set {ETH_ENV})"


def _extract_member(zpath: Path, member: str, cache: Path) -> Path:
    with zipfile.ZipFile(zpath) as zf:
        names = [n for n in zf.namelist() if Path(n).name == member]
        if len(names) != 1:
            raise DataError(f"{zpath}: expected one member named {member!r}; found {names}")
        dest = cache / zpath.stem / names[0]
        if not dest.is_file():
            zf.extract(names[0], cache / zpath.stem)
    return dest


def set_paths(entry: RealSet, cache_dir=None) -> tuple[Path, Path]:
    """The two pose files of ``entry`` (ETH members unpacked into ``cache_dir``)."""
    ok, why = set_available(entry)
    if not ok:
        raise DataError(f"data set {entry.name}: {why}")
    if entry.source == "real":
        d = real_dir() / entry.folder
        return d / entry.file_a, d / entry.file_b
    cache = Path(cache_dir) if cache_dir is not None else _default_cache()
    z = eth_dir() / entry.folder
    return _extract_member(z, entry.file_a, cache), _extract_member(z, entry.file_b, cache)


# ------------------------------------------------------------------------ the reference
@dataclass(frozen=True, eq=False)
class Reference:
    """``T_a_b`` of the reference, its kind, its stated spread (``spread_deg``,
    ``spread_m``: the max deviation of a member, or None) and ``covariance`` (6x6 isotropic,
    per-axis sigma = spread / sqrt(3), so the RMS of the error norm is the spread; None
    without a stated spread)."""
    T_a_b: np.ndarray
    kind: str
    text: str
    spread_deg: float | None = None
    spread_m: float | None = None

    @property
    def covariance(self) -> np.ndarray | None:
        if self.spread_deg is None or self.spread_m is None:
            return None
        var_r = (math.radians(self.spread_deg) / math.sqrt(3.0)) ** 2
        var_t = (self.spread_m / math.sqrt(3.0)) ** 2
        return np.diag([var_r] * 3 + [var_t] * 3)


_SPREAD = re.compile(r"max deviation of a member\s+([0-9.]+)\s*deg\s*/\s*([0-9.]+)\s*mm")
_SCARA = re.compile(r"translation\s*\[([^\]]+)\]\s*m,\s*rotation Euler xyz\s*\[([^\]]+)\]\s*deg")


def _numbers(text: str, n: int, where: str) -> np.ndarray:
    v = np.array([float(x) for x in text.split(",")])
    if v.shape != (n,):
        raise DataError(f"{where}: expected {n} numbers; read {text!r}")
    return v


def read_reference_file(path) -> Reference:
    """``reference_X_T_a_b.txt``: a header comment (with the spread where stated) and a 4x4."""
    from simcalib.geometry import check_transforms
    path = Path(path)
    text = path.read_text()
    X = np.loadtxt(path, comments="#")
    if X.shape != (4, 4):
        raise DataError(f"{path}: expected a 4x4 matrix; read shape {X.shape}")
    try:
        check_transforms(X[None], str(path))
    except ValueError as exc:
        raise DataError(str(exc)) from None
    m = _SPREAD.search(text)
    header = text.splitlines()[0].lstrip("# ").strip()
    return Reference(X, "file", header, float(m.group(1)) if m else None,
                     1e-3 * float(m.group(2)) if m else None)


def read_readme_reference(path) -> Reference:
    """The scara README's "Ground Truth Hand to Camera": translation (m), Euler xyz (deg)."""
    from scipy.spatial.transform import Rotation
    text = Path(path).read_text()
    m = _SCARA.search(text)
    if m is None:
        raise DataError(f"{path}: no 'translation [..] m, rotation Euler xyz [..] deg' found")
    t = _numbers(m.group(1), 3, str(path))
    euler = _numbers(m.group(2), 3, str(path))
    X = np.eye(4)
    X[:3, :3] = Rotation.from_euler("xyz", euler, degrees=True).as_matrix()
    X[:3, 3] = t
    return Reference(X, "readme", f"README: t = {t.tolist()} m, Euler xyz {euler.tolist()} deg")


def read_tum(path) -> tuple[np.ndarray, np.ndarray]:
    """A TUM file read plainly (``t x y z qx qy qz qw``, '#' comments): stamps, (N,4,4)."""
    from simcalib.geometry import matrix_from_quat
    d = np.loadtxt(path, comments="#", ndmin=2)
    if d.shape[1] != 8:
        raise DataError(f"{path}: expected 8 columns (t x y z qx qy qz qw); read {d.shape[1]}")
    T = np.tile(np.eye(4), (d.shape[0], 1, 1))
    q = d[:, 4:8] / np.linalg.norm(d[:, 4:8], axis=1, keepdims=True)
    T[:, :3, :3] = matrix_from_quat(q)
    T[:, :3, 3] = d[:, 1:4]
    return d[:, 0], T


def _opencv_reference(pa: Path, pb: Path) -> Reference:
    ta, Ta = read_tum(pa)
    tb, Tb = read_tum(pb)
    common, ia, ib = np.intersect1d(ta, tb, return_indices=True)
    if common.size < 3:
        raise DataError(f"{pa.parent}: {common.size} common stamps; the OpenCV reference "
                        "needs synchronous pairs")
    X = _opencv(Ta[ia], Tb[ib], "CALIB_HAND_EYE_PARK")
    if X is None:
        raise DataError(f"{pa.parent}: OpenCV PARK failed on the stamp-matched pairs")
    return Reference(X, "opencv", f"OpenCV PARK (all pairs) on the {common.size} "
                     "stamp-matched pose pairs of the files")


def load_reference(entry: RealSet, paths=None) -> Reference | None:
    """The reference of ``entry`` (None when it has none)."""
    if entry.reference is None:
        return None
    if entry.reference == "identity":
        return Reference(np.eye(4), "identity", "identity (both streams track one frame)")
    folder = real_dir() / entry.folder
    if entry.reference == "file":
        return read_reference_file(folder / "reference_X_T_a_b.txt")
    if entry.reference == "readme":
        return read_readme_reference(folder / "README.md")
    if entry.reference == "opencv":
        pa, pb = paths if paths is not None else set_paths(entry)
        return _opencv_reference(Path(pa), Path(pb))
    raise DataError(f"data set {entry.name}: unknown reference kind {entry.reference!r}")


def reference_tolerance(entry: RealSet, ref: Reference | None) -> tuple:
    """``(rotation_deg, translation_m)`` of "correct" (the crwhe sets: the reference's
    spread); None where the README gives none."""
    tol = entry.tolerance
    if tol is None:
        return None, None
    if tol.rotation_deg is None and tol.translation_m is None and ref is not None \
            and ref.spread_deg is not None:
        return ref.spread_deg, ref.spread_m
    return tol.rotation_deg, tol.translation_m


# ------------------------------------------------------------------------------- NEES
@dataclass(frozen=True)
class Nees:
    """``value = e^T S^+ e`` over ``axes`` (the components used), ``dof`` the rank of ``S``
    there, ``bound_95`` the chi-square(dof) 95 % quantile."""
    value: float
    dof: int
    bound_95: float
    axes: tuple

    @property
    def within(self) -> bool:
        return self.dof > 0 and self.value <= self.bound_95


@functools.lru_cache(maxsize=None)
def chi2_bound_95(dof: int) -> float:
    """The chi-square(dof) 95 % quantile (12.59 for 6); NaN for 0 dof."""
    from scipy.special import chdtri
    return float(chdtri(dof, 0.05)) if dof > 0 else float("nan")


def _as_covariance(cov) -> np.ndarray:
    a = np.array([[np.inf if x is None else float(x) for x in row] for row in cov],
                 dtype=np.float64)
    if a.shape != (6, 6):
        raise ValueError(f"covariance must be 6x6; received shape {a.shape}")
    return a


def nees(error, covariance, axes=ALL_AXES, extra_covariance=None,
         rel_tol: float = 1e-12) -> Nees | None:
    """NEES of the 6-vector ``error`` (order of :func:`pose_error`) against ``covariance``
    (6x6; None / inf / nan entries mark undetermined axes): only the axes whose variance is
    finite and that ``axes`` selects are used; on them ``S`` (+ ``extra_covariance``, e.g.
    the reference's own) is pseudo-inverted (eigenvalues below ``rel_tol`` times the largest
    dropped) and ``dof`` is its rank. None when no covariance."""
    if covariance is None:
        return None
    e = np.asarray(error, dtype=np.float64).reshape(6)
    S = _as_covariance(covariance)
    use = np.isfinite(np.diag(S)) & np.asarray(axes, dtype=bool)
    idx = np.flatnonzero(use)
    if idx.size == 0:
        return Nees(float("nan"), 0, float("nan"), ())
    Ss = S[np.ix_(idx, idx)]
    if not np.isfinite(Ss).all():
        raise ValueError("covariance has non-finite entries between axes of finite variance")
    if extra_covariance is not None:
        Ss = Ss + np.asarray(extra_covariance, dtype=np.float64)[np.ix_(idx, idx)]
    lam, V = np.linalg.eigh(0.5 * (Ss + Ss.T))
    keep = lam > rel_tol * max(lam[-1], 0.0)
    if not keep.any():
        return Nees(float("nan"), 0, float("nan"), tuple(int(i) for i in idx))
    c = V[:, keep].T @ e[idx]
    value = float(np.sum(c * c / lam[keep]))
    dof = int(keep.sum())
    return Nees(value, dof, chi2_bound_95(dof), tuple(int(i) for i in idx))


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class FlaggedDirection:
    reason: str
    kind: str
    rotation_axis_a: tuple
    translation_dir_a: tuple
    description: str


@dataclass(frozen=True, eq=False)
class MethodResult:
    """An OpenCV estimate on the calibration's synchronised poses (``X`` None: failed)."""
    method: str
    X: np.ndarray | None
    rotation_error_deg: float | None
    translation_error_mm: float | None
    poses_used: int
    message: str = ""
    rotation_diff_deg: float | None = None       # vs simcalib's X (all sets)
    translation_diff_mm: float | None = None


@dataclass(frozen=True, eq=False)
class SetResult:
    """One set calibrated with the defaults. ``exit_code``: the command's status (0, 6;
    3 / 5 / 1 when it raised, ``error`` then holds the message). ``covariance``: the
    reported 6x6 (inf on undetermined axes). Errors vs the reference: ``pose_error``
    (rotation norm; translation norm over the reference's valid axes)."""
    name: str
    exit_code: int
    status: str
    error: str
    wall_time_s: float
    X: np.ndarray | None = None
    covariance: np.ndarray | None = None
    std_rot_deg: tuple | None = None
    std_trans_mm: tuple | None = None
    verdict: str = ""
    flagged: tuple = ()
    offset_s: float | None = None
    offset_sigma_s: float | None = None
    n_inliers: int | None = None
    n_motions: int | None = None
    reference: Reference | None = None
    error_vector: np.ndarray | None = None
    rotation_error_deg: float | None = None
    translation_error_mm: float | None = None
    nees: Nees | None = None
    nees_with_reference: Nees | None = None
    park: MethodResult | None = None
    tsai: MethodResult | None = None
    #: the reference-free split-half check (X of the recording's first half against its
    #: second, :class:`simcalib.estimation.consistency.SplitCheck`) as a :class:`Nees`
    split: "Nees | None" = None

    @property
    def ran(self) -> bool:
        return self.exit_code in (0, 6)

    @property
    def nees_target(self) -> Nees | None:
        """The NEES the 80 % target uses: with the reference's own accuracy added
        (:func:`reference_accuracy`) where it has one."""
        return self.nees_with_reference if self.nees_with_reference is not None else self.nees


def _reference_errors(ref: Reference, X, entry: RealSet):
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    e = pose_error(ref.T_a_b, X)
    axes = entry.tolerance.translation_axes if entry.tolerance is not None else (True,) * 3
    trans = e[3:][np.asarray(axes, dtype=bool)]
    return e, math.degrees(float(np.linalg.norm(e[:3]))), 1e3 * float(np.linalg.norm(trans))


def _opencv(T_a, T_b, const: str) -> np.ndarray | None:
    """``cv2.calibrateHandEye`` with gripper2base = ``T_a`` (T_wa_a), target2cam =
    ``T_b^-1``: its cam2gripper is ``X = T_a_b``. None when OpenCV fails or is missing."""
    from simcalib.geometry import invert_transform
    try:
        import cv2
    except ImportError:
        return None
    if not hasattr(cv2, "calibrateHandEye"):
        return None
    Tc = invert_transform(T_b)
    try:
        R, t = cv2.calibrateHandEye(
            [np.ascontiguousarray(m) for m in T_a[:, :3, :3]],
            [np.ascontiguousarray(m) for m in T_a[:, :3, 3:4]],
            [np.ascontiguousarray(m) for m in Tc[:, :3, :3]],
            [np.ascontiguousarray(m) for m in Tc[:, :3, 3:4]], method=getattr(cv2, const))
    except cv2.error:
        return None
    X = np.eye(4)
    X[:3, :3] = np.asarray(R, dtype=np.float64)
    X[:3, 3] = np.asarray(t, dtype=np.float64).ravel()
    if not np.isfinite(X).all() or np.array_equal(X, np.eye(4)):
        return None
    return X


def subsample_indices(n: int, max_poses: int = OPENCV_MAX_POSES) -> np.ndarray:
    """At most ``max_poses`` indices of ``n``, evenly spread (deterministic)."""
    if n <= max_poses:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_poses).round().astype(int))


def opencv_estimates(T_a, T_b, ref: Reference | None, entry: RealSet,
                     X_estimate=None) -> tuple:
    """PARK and TSAI on the synchronised poses (at most :data:`OPENCV_MAX_POSES`, evenly
    spread: OpenCV pairs all i<j), their errors vs ``ref`` and their differences from
    ``X_estimate`` (simcalib's X)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    k = subsample_indices(T_a.shape[0])
    out = []
    for name, const in (("PARK", "CALIB_HAND_EYE_PARK"), ("TSAI", "CALIB_HAND_EYE_TSAI")):
        X = _opencv(T_a[k], T_b[k], const) if k.size >= 3 else None
        rot = trans = d_rot = d_trans = None
        if X is not None and ref is not None:
            _, rot, trans = _reference_errors(ref, X, entry)
        if X is not None and X_estimate is not None:
            d = pose_error(X, X_estimate)
            d_rot = math.degrees(float(np.linalg.norm(d[:3])))
            d_trans = 1e3 * float(np.linalg.norm(d[3:]))
        out.append(MethodResult(name, X, rot, trans, int(k.size),
                                "" if X is not None else "cv2.calibrateHandEye failed",
                                d_rot, d_trans))
    return tuple(out)


def _flagged(solution, assessment=None) -> tuple:
    """The verdict's flagged directions (the assessment's; without one, the solver's)."""
    dirs = getattr(assessment, "directions", None)
    if dirs is None:
        unc = None if solution is None else solution.uncertainty
        dirs = () if unc is None else unc.directions
    return tuple(FlaggedDirection(d.reason, d.kind, tuple(map(float, d.rotation_axis_a)),
                                  tuple(map(float, d.translation_dir_a)), d.description)
                 for d in dirs)


def _calibrate(entry: RealSet, pa: Path, pb: Path, out: Path):
    from simcalib.pipeline.calibrate import calibrate, parse_options
    from simcalib.report.calibration import report_dict
    opts = parse_options([f"a={pa}", f"b={pb}", f"output={out}", "recording=false"])
    r, a = calibrate(opts)
    return r, a, report_dict(opts, r, a)


def _failed(entry, code, msg, wall, ref) -> SetResult:
    return SetResult(entry.name, code, "error", msg, wall, reference=ref)


def run_set(entry: RealSet, *, cache_dir=None) -> SetResult:
    """Calibrate ``entry`` with the ``calibrate`` defaults (library, outputs in a temporary
    folder, ``recording=false``) and evaluate it (:class:`SetResult`). An error of the
    calibration is recorded (its exit code and message), not raised; missing data raise
    :class:`DataError`."""
    from simcalib.errors import exit_code
    pa, pb = set_paths(entry, cache_dir)
    ref = load_reference(entry, (pa, pb))
    with tempfile.TemporaryDirectory(prefix=f"simcalib_real_{entry.name}_") as tmp:
        t0 = time.perf_counter()
        try:
            r, a, rep = _calibrate(entry, pa, pb, Path(tmp) / "out")
        except Exception as exc:  # noqa: BLE001 - recorded: refusals and crashes are results
            wall = time.perf_counter() - t0
            return _failed(entry, exit_code(exc), f"{type(exc).__name__}: {exc}", wall, ref)
        wall = time.perf_counter() - t0
    return _evaluate(entry, r, a, rep, ref, wall)


def _mm(v):
    return None if v is None else tuple(None if x is None else 1e3 * x for x in v)


def reference_accuracy(entry: RealSet, ref: Reference | None) -> np.ndarray | None:
    """The reference's own error as a 6x6 covariance (order of :func:`pose_error`): its
    stated spread where it states one (crwhe); otherwise the README's "correct" tolerance
    read as the 95 % bound of the reference's error norm (per-axis sigma = tolerance /
    sqrt(chi2_3(0.95)) = tolerance / 2.80); an axis without a tolerance gets none (it is
    not compared). None without a reference or a tolerance."""
    if ref is None:
        return None
    if ref.covariance is not None:
        return ref.covariance
    tol = entry.tolerance
    if tol is None or (tol.rotation_deg is None and tol.translation_m is None):
        return None
    k = math.sqrt(chi2_bound_95(3))
    var_r = 0.0 if tol.rotation_deg is None else (math.radians(tol.rotation_deg) / k) ** 2
    var_t = 0.0 if tol.translation_m is None else (tol.translation_m / k) ** 2
    return np.diag([var_r] * 3 + [var_t] * 3)


def _evaluate(entry, r, a, rep, ref, wall) -> SetResult:
    X = np.asarray(rep["X"]["T_a_b"], dtype=np.float64)
    cov = None if a.covariance is None else _as_covariance(a.covariance)
    e = rot = trans = n0 = n1 = None
    if ref is not None:
        e, rot, trans = _reference_errors(ref, X, entry)
        n0 = nees(e, cov, entry.nees_axes)
        acc = reference_accuracy(entry, ref)
        if acc is not None:
            n1 = nees(e, cov, entry.nees_axes, extra_covariance=acc)
    park, tsai = opencv_estimates(np.asarray(r.synced.T_a), np.asarray(r.synced.T_b), ref,
                                  entry, X)
    off, inl = rep["time_offset"], rep["inliers"]
    sc = getattr(r.consistency, "split", None)
    split = None if sc is None else Nees(sc.nees, sc.dof, sc.bound, ())
    return SetResult(
        entry.name, int(rep["exit_code"]), rep["status"], "", wall, X, cov, a.std_rot_deg,
        _mm(a.std_trans_m), a.verdict, _flagged(r.robust.solution, a), off["offset_s"],
        off["uncertainty_s"], inl["n_inliers"], inl["n_motions"], ref, e, rot, trans, n0, n1,
        park, tsai, split)


# ----------------------------------------------------------------------------- checks
def tolerance_check(entry: RealSet, res: SetResult) -> tuple[bool, str]:
    """``(ok, why)``: X within the README's tolerance of the reference, or consistent with
    it within both uncertainties (the NEES with the reference's own accuracy within its
    95 % bound: the reported sigma covers the difference); and the offset within its
    tolerance where one is expected. ``ok`` is True when nothing is to check."""
    if not res.ran:
        return False, f"exit {res.exit_code}: {res.error}"
    why = []
    rot_tol, trans_tol = reference_tolerance(entry, res.reference)
    if res.reference is not None:
        if rot_tol is not None and res.rotation_error_deg > rot_tol:
            why.append(f"rotation error {res.rotation_error_deg:.3f} deg > {rot_tol:g} deg")
        waived = entry.tolerance.waive_translation_if_flagged and any(
            f.kind in ("translation", "coupled") for f in res.flagged)
        if trans_tol is not None and not waived and res.translation_error_mm > 1e3 * trans_tol:
            why.append(f"translation error {res.translation_error_mm:.1f} mm > "
                       f"{1e3 * trans_tol:g} mm")
    consistent = (res.nees_with_reference is not None and res.nees_with_reference.within)
    if why and consistent:      # not within the tolerance, but the sigma covers the gap
        why = []
    tol = entry.tolerance
    if tol is not None and tol.offset_s is not None:
        if abs(res.offset_s - tol.offset_s) > tol.offset_tolerance_s:
            why.append(f"offset {1e3 * res.offset_s:.1f} ms, expected {1e3 * tol.offset_s:.0f}"
                       f" +- {1e3 * tol.offset_tolerance_s:.0f} ms")
    return not why, "; ".join(why)


def method_within_tolerance(entry: RealSet, res: SetResult, method: str) -> bool:
    """OpenCV ``method`` (``park`` / ``tsai``) on the same synchronised poses within the
    README's X tolerance (a baseline: no flags, no offset)."""
    m = getattr(res, method)
    if m is None or m.rotation_error_deg is None:
        return False
    rot_tol, trans_tol = reference_tolerance(entry, res.reference)
    return ((rot_tol is None or m.rotation_error_deg <= rot_tol)
            and (trans_tol is None or m.translation_error_mm <= 1e3 * trans_tol))


def _matches(req: RequiredFlag, f: FlaggedDirection) -> bool:
    if f.reason not in req.reasons:
        return False
    v = np.asarray(f.translation_dir_a if req.kind == "translation" else f.rotation_axis_a)
    return abs(float(v @ np.asarray(req.axis_a))) >= req.min_cos


def flag_check(entry: RealSet, res: SetResult) -> tuple[bool, str]:
    """``(ok, why)``: every required direction is among the flagged ones."""
    if not res.ran:
        return False, f"exit {res.exit_code}: {res.error}"
    missing = [q.text for q in entry.required_flags
               if not any(_matches(q, f) for f in res.flagged)]
    got = "; ".join(f"{f.reason}: {f.description}" for f in res.flagged) or "none"
    return not missing, ("" if not missing else
                         f"not flagged: {', '.join(missing)} (flagged: {got}; verdict "
                         f"{res.verdict})")


@dataclass(frozen=True, eq=False)
class Agreement:
    """Difference ``pose_error(X_1, X_2)`` (or of a loop) against the combined reported
    covariance: ``ratio`` = |difference| / combined sigma per axis (–: undetermined),
    ``ok``: every finite ratio within :data:`AGREEMENT_SIGMA`; ``nees`` over the finite axes."""
    names: tuple
    difference: np.ndarray | None
    ratio: np.ndarray | None
    nees: Nees | None
    ok: bool
    message: str


def _combined(covs) -> np.ndarray | None:
    if any(c is None for c in covs):
        return None
    return np.sum([np.where(np.isfinite(c), c, np.inf) for c in covs], axis=0)


def _agreement_from(names, d, S) -> Agreement:
    if S is None:
        return Agreement(names, d, None, None, False, "no covariance")
    sig = np.sqrt(np.diag(S))
    ratio = np.where(np.isfinite(sig), np.abs(d) / sig, np.nan)
    fin = np.isfinite(ratio)
    ok = bool(fin.any() and np.all(ratio[fin] <= AGREEMENT_SIGMA))
    return Agreement(names, d, ratio, nees(d, S), ok,
                     f"max |diff| / sigma {np.nanmax(ratio) if fin.any() else float('nan'):.2f}"
                     f" over {int(fin.sum())} axes")


def agreement(r1: SetResult, r2: SetResult) -> Agreement:
    """The two X of sets sharing a mount, against their combined covariance plus how well
    the READMEs say the mounts agree (:data:`STATED_AGREEMENT`)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    names = (r1.name, r2.name)
    if not (r1.ran and r2.ran):
        return Agreement(names, None, None, None, False,
                         f"{r1.name} exit {r1.exit_code}, {r2.name} exit {r2.exit_code}")
    covs = [r1.covariance, r2.covariance]
    stated = STATED_AGREEMENT.get(names)
    if stated is not None:          # the mounts are known to agree only this well
        k = math.sqrt(chi2_bound_95(3))
        covs.append(np.diag([(math.radians(stated[0]) / k) ** 2] * 3
                            + [(stated[1] / k) ** 2] * 3))
    return _agreement_from(names, pose_error(r1.X, r2.X), _combined(covs))


def loop_agreement(r_ab: SetResult, r_bc: SetResult, r_ac: SetResult) -> Agreement:
    """``X_ac`` vs ``X_ab X_bc`` against the first-order covariance of the product plus
    ``Sigma_ac``. In :func:`pose_error`'s convention (rotation left-perturbed, translation
    added, frame a) an error ``(w1, v1)`` of ``X_ab`` moves the product by ``(w1, v1 -
    [R_ab t_bc]x w1)`` and an error ``(w2, v2)`` of ``X_bc`` (frame b) by ``(R_ab w2,
    R_ab v2)``."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    names = (r_ab.name, r_bc.name, r_ac.name)
    if not (r_ab.ran and r_bc.ran and r_ac.ran):
        return Agreement(names, None, None, None, False, "a set of the loop did not run")
    d = pose_error(r_ac.X, r_ab.X @ r_bc.X)
    if any(r.covariance is None for r in (r_ab, r_bc, r_ac)):
        return Agreement(names, d, None, None, False, "no covariance")
    from simcalib.geometry import skew_matrix
    R_ab, t_bc = r_ab.X[:3, :3], r_bc.X[:3, 3]
    J_ab = np.eye(6)
    J_ab[3:, :3] = -skew_matrix(R_ab @ t_bc)
    J_bc = np.zeros((6, 6))
    J_bc[:3, :3] = J_bc[3:, 3:] = R_ab
    S = (propagate_covariance(J_ab, r_ab.covariance) + propagate_covariance(J_bc, r_bc.covariance)
         + r_ac.covariance)
    return _agreement_from(names, d, S)


def propagate_covariance(J, S) -> np.ndarray:
    """``J S J^T`` where ``S`` may hold inf on undetermined axes: those axes' images
    (the rows of ``J`` that touch them) become inf, the rest is propagated normally."""
    S = np.asarray(S, dtype=np.float64)
    bad = ~np.isfinite(np.diag(S))
    out = J @ np.where(np.isfinite(S), S, 0.0) @ J.T
    if bad.any():
        touched = np.abs(J[:, bad]).sum(axis=1) > 1e-12
        out[touched, :] = 0.0
        out[:, touched] = 0.0
        out[touched, touched] = np.inf
    return out


# ---------------------------------------------------------------------------- summary
@dataclass(frozen=True)
class Summary:
    n_sets: int
    n_ran: int
    n_exit0: int
    n_exit6: int
    n_referenced: int
    n_within_reference: int
    n_nees_sets: int
    n_nees_within: int
    n_flags_required: int
    n_flags_ok: int
    n_offsets: int
    n_offsets_ok: int
    n_park_within: int
    n_tsai_within: int
    agreements: tuple
    loops: tuple
    n_strictly_within: int = 0      # within the tolerance itself (not only consistent)
    n_nees_plain_within: int = 0    # NEES with the estimate's covariance alone
    n_split_sets: int = 0           # sets whose two halves could be compared
    n_split_within: int = 0         # ... within the 95 % bound of their predicted difference

    @property
    def nees_share(self) -> float:
        return self.n_nees_within / self.n_nees_sets if self.n_nees_sets else float("nan")


def _pairs(results: dict, pairs) -> tuple:
    return tuple(agreement(results[a], results[b]) for a, b in pairs
                 if a in results and b in results)


def summarise(results: dict) -> Summary:
    """Counts over ``{name: SetResult}``."""
    ents = {n: set_by_name(n) for n in results}
    ran = [r for r in results.values() if r.ran]
    refd = [n for n, e in ents.items() if e.reference is not None]
    within = [n for n in refd if tolerance_check(ents[n], results[n])[0]]
    nsets = [n for n in refd if ents[n].independent_reference]
    nin = [n for n in nsets if results[n].nees_target is not None
           and results[n].nees_target.within]
    flg = [n for n, e in ents.items() if e.required_flags]
    offs = [n for n, e in ents.items() if e.tolerance is not None
            and e.tolerance.offset_s is not None]
    offs_ok = [n for n in offs if results[n].ran and abs(
        results[n].offset_s - ents[n].tolerance.offset_s) <= ents[n].tolerance.offset_tolerance_s]
    loops = tuple(loop_agreement(*(results[n] for n in lp)) for lp in LOOPS
                  if all(n in results for n in lp))
    return Summary(len(results), len(ran), sum(r.exit_code == 0 for r in ran),
                   sum(r.exit_code == 6 for r in ran), len(refd), len(within), len(nsets),
                   len(nin), len(flg), sum(flag_check(ents[n], results[n])[0] for n in flg),
                   len(offs), len(offs_ok),
                   sum(method_within_tolerance(ents[n], results[n], "park") for n in refd),
                   sum(method_within_tolerance(ents[n], results[n], "tsai") for n in refd),
                   _pairs(results, CROSS_SET_PAIRS), loops,
                   sum(_strictly_within(ents[n], results[n]) for n in refd),
                   sum(results[n].nees is not None and results[n].nees.within for n in nsets),
                   sum(r.split is not None for r in ran),
                   sum(r.split is not None and r.split.within for r in ran))


def _strictly_within(entry: RealSet, res: SetResult) -> bool:
    """X within the README's tolerance itself (rotation and the valid translation)."""
    if not res.ran or res.reference is None:
        return False
    rot_tol, trans_tol = reference_tolerance(entry, res.reference)
    return ((rot_tol is None or res.rotation_error_deg <= rot_tol)
            and (trans_tol is None or res.translation_error_mm <= 1e3 * trans_tol))


# --------------------------------------------------------------------------- markdown
def _f(x, fmt="{:.2f}"):
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else fmt.format(x)


def _vec(v, fmt="{:.1f}"):
    if v is None:
        return "–"
    return ", ".join("inf" if x is None or not math.isfinite(x) else fmt.format(x) for x in v)


def _x_cells(r: SetResult) -> tuple[str, str]:
    if r.X is None:
        return "–", "–"
    from simcalib.geometry import rotvec_from_matrix
    return (_vec(1e3 * r.X[:3, 3]), _vec(np.degrees(rotvec_from_matrix(r.X[:3, :3])), "{:.2f}"))


def _nees_cell(n: Nees | None) -> str:
    if n is None:
        return "–"
    if n.dof == 0:
        return "no finite axis"
    return f"{n.value:.2f} ({n.dof}; {n.bound_95:.2f}){'' if n.within else ' ✗'}"


def _method_cell(m: MethodResult | None) -> str:
    if m is None:
        return "–"
    if m.X is None:
        return "failed"
    if m.rotation_error_deg is None:
        return f"(no ref; Δ X {m.rotation_diff_deg:.2f} / {m.translation_diff_mm:.1f})"
    return f"{m.rotation_error_deg:.2f} / {m.translation_error_mm:.1f}"


def _row(entry: RealSet, r: SetResult) -> str:
    t, rv = _x_cells(r)
    ok_tol, why_tol = tolerance_check(entry, r)
    ok_flag, why_flag = flag_check(entry, r)
    checked = entry.reference is not None or entry.required_flags or (
        entry.tolerance is not None and entry.tolerance.offset_s is not None)
    checks = "FAIL" if not (ok_tol and ok_flag) else ("ok" if checked else "–")
    ref = entry.reference or "none"
    err = ("–" if r.rotation_error_deg is None else
           f"{r.rotation_error_deg:.2f} / {r.translation_error_mm:.1f}")
    flagged = "; ".join(f"{f.reason[:4]}. {f.kind}" for f in r.flagged) or "–"
    inl = "–" if r.n_motions is None else f"{r.n_inliers}/{r.n_motions}"
    off = "–" if r.offset_s is None else f"{1e3 * r.offset_s:.1f}" + (
        f" ± {1e3 * r.offset_sigma_s:.1f}" if r.offset_sigma_s else "")
    status = f"{r.exit_code}" + ("" if r.ran else f" ({r.error[:90]})")
    return (f"| {entry.name} | {status} | {r.verdict or '–'} | {t} | {rv} | "
            f"{_vec(r.std_rot_deg, '{:.2f}')} | {_vec(r.std_trans_mm)} | {flagged} | {off} | "
            f"{inl} | {r.wall_time_s:.1f} | {ref} | {err} | {_nees_cell(r.nees)} | "
            f"{_nees_cell(r.nees_with_reference)} | {_nees_cell(r.split)} | "
            f"{_method_cell(r.park)} | {_method_cell(r.tsai)} | {checks} |")


_HEAD = ("| set | exit | verdict | X t (mm) | X rotvec (deg) | 1σ rot (deg) | 1σ t (mm) | "
         "flagged | offset (ms) | inliers / motions | time (s) | reference | error rot (deg) /"
         " t (mm) | NEES (dof; 95 %) | NEES + ref accuracy | split-half NEES | PARK err | "
         "TSAI err | checks |\n"
         "|" + "---|" * 19)


def _agreement_line(g: Agreement) -> str:
    if g.ratio is None:
        return f"- {' vs '.join(g.names)}: not evaluated ({g.message})"
    d = g.difference
    return (f"- {' vs '.join(g.names)}: difference {math.degrees(np.linalg.norm(d[:3])):.3f}"
            f" deg / {1e3 * np.linalg.norm(d[3:]):.1f} mm; |diff| / combined sigma per axis "
            f"[{', '.join('–' if not np.isfinite(x) else f'{x:.1f}' for x in g.ratio)}] "
            f"(–: undetermined); {'within' if g.ok else 'NOT within'} "
            f"{AGREEMENT_SIGMA:g} sigma; NEES {_nees_cell(g.nees)}")


def _failures(results: dict) -> list[str]:
    out = []
    for n, r in results.items():
        e = set_by_name(n)
        whys = [why for ok, why in (tolerance_check(e, r), flag_check(e, r)) if not ok]
        out += [f"{n}: {w}" for w in dict.fromkeys(whys)]
    return out


def markdown(results: dict, *, command: str, total_time_s: float) -> str:
    """The document of ``{name: SetResult}``."""
    s = summarise(results)
    rows = "\n".join(_row(set_by_name(n), r) for n, r in results.items())
    share = "n/a" if not s.n_nees_sets else f"{100 * s.nees_share:.0f} %"
    lines = [
        "# Real-data regression table", "",
        "Generated by `simcalib.studies.experiments.real_data`; regenerate with", "", "```",
        command, "```", "",
        "Every public recording of `../shared/data/real` and `../shared/data/eth` calibrated "
        "with the `calibrate` **defaults** (`a=`, `b=`, `output=` only; `recording=false`), "
        "through the library (`simcalib.pipeline.calibrate.calibrate`). "
        "`tests/test_studies_experiments_real_data.py` checks the same numbers (skipped without the data).", "",
        "## Summary", "",
        f"- **{s.n_ran} of {s.n_sets}** sets exit 0 or 6 ({s.n_exit0} exit 0, {s.n_exit6} exit"
        f" 6); {s.n_sets - s.n_ran} refuse or crash.",
        f"- **{s.n_within_reference} of {s.n_referenced}** referenced sets within the "
        "README's tolerance or consistent with the reference within both uncertainties "
        "(and the offset where one is expected); strictly within the tolerance: "
        f"{s.n_strictly_within}. Baseline on the same synchronised poses, X strictly within:"
        f" OpenCV PARK {s.n_park_within}, TSAI {s.n_tsai_within} of {s.n_referenced} (the "
        "`opencv` references are PARK itself on the files).",
        f"- Required directions flagged on **{s.n_flags_ok} of {s.n_flags_required}** sets.",
        f"- Clock offset within its expected value on **{s.n_offsets_ok} of {s.n_offsets}** "
        "sets that have one.",
        f"- NEES within its 95 % bound on **{s.n_nees_within} of {s.n_nees_sets}** sets with "
        f"an independent reference ({share}; target ≥ {100 * NEES_TARGET_SHARE:.0f} %), with "
        "the reference's own accuracy added; with the estimate's covariance alone "
        f"{s.n_nees_plain_within} of {s.n_nees_sets}.",
        f"- Reference-free split-half check (X of the recording's first half against its "
        f"second, their difference against the covariance the pose-error model predicts for "
        f"it) within its 95 % bound on **{s.n_split_within} of {s.n_split_sets}** sets whose "
        "halves could be compared.",
        "- Cross-set agreement (sets sharing a mount; loop of three streams of one rig):",
        *["  " + _agreement_line(g) for g in (*s.agreements, *s.loops)],
        f"- Total wall time of the calibrations {sum(r.wall_time_s for r in results.values()):.1f}"
        f" s (this run: {total_time_s:.1f} s with references and OpenCV).", "",
        "## Table", "", _HEAD, rows, "",
        "## Failed checks", "",
        *([f"- {x}" for x in _failures(results)] or ["- none"]), "",
        "## How to read it", "",
        "- **X**: `T_a_b`, translation in mm, rotation vector in degrees. **1σ**: the "
        "reported per-axis standard deviation (frame a; inf = undetermined).",
        "- **flagged**: the directions of the verdict (`unde.` undetermined, `poor.` poorly "
        "determined).",
        "- **error**: `pose_error(X_ref, X)` of `simcalib.solvers.diagnostics.uncertainty` "
        "(rotation vector of `R_ref R^T`, `t_ref - t`, frame a): its rotation norm, and the "
        "translation norm over the reference's valid axes (scara: x, y).",
        "- **NEES**: `e^T S^+ e` on the axes whose reported variance is finite and that the "
        "reference pins (euroc, kitti: rotation only; scara: not z), `S^+` the "
        "pseudo-inverse there; dof = its rank; ✗ = above the chi-square 95 % quantile "
        "(12.59 for 6 dof). **NEES + ref accuracy** adds the reference's own error "
        "(`reference_accuracy`): the crwhe header's spread (max member deviation, "
        "isotropic, per-axis sigma = spread / √3); elsewhere the README's 'correct' "
        "tolerance read as the 95 % bound of the reference's error norm (per-axis sigma = "
        "tolerance / 2.80; an axis without a tolerance adds nothing). The **80 % target "
        "uses NEES + ref accuracy**, over the sets with an independent reference (file, "
        "README, identity); the `opencv` references (kuka, sthe: the README's 'correct' is "
        "relative to OpenCV on the same files) count for the tolerance only.",
        "- **split-half NEES**: the reference-free check of the reported sigma "
        "(`simcalib.estimation.consistency.SplitCheck`): X estimated on the recording's "
        "first and on its second half of poses (each half's own motions), their difference "
        "against the covariance the fitted pose-error model predicts for it (errors common "
        "to the whole recording cancel in the difference, which tests the sigma's varying "
        "part); ✗ = above the chi-square 95 % bound, and the reported covariance was then "
        "scaled by NEES / bound (the data disagree with themselves beyond the model).",
        f"- **PARK / TSAI**: `cv2.calibrateHandEye` on the calibration's synchronised poses "
        f"(readings applied; at most {OPENCV_MAX_POSES} evenly spread poses, OpenCV pairs "
        "all i<j), error vs the reference as above (rot deg / t mm); without a reference "
        "`Δ X`: its difference from simcalib's X.",
        "- **checks**: X within the README tolerance (crwhe: the reference's spread) or "
        "consistent with the reference within both uncertainties (NEES + ref accuracy "
        "within its bound: an honest answer is accurate or says how far it may be off), "
        "the expected offset where one is known, the required flagged directions.",
        f"- Cross-set agreement: `pose_error(X_1, X_2)` per axis against the combined "
        f"(summed) reported sigma plus how well the READMEs say the mounts agree (kuka "
        f"0.1 deg / 6 mm, sthe 0.3 deg / 5 mm, read as 95 % bounds); within = every "
        f"determined axis ≤ {AGREEMENT_SIGMA:g} sigma.",
        "- The references are not ground truth: only the crwhe files state a spread; "
        "scara's is measured by hand, Tabb's is another method's estimate, the identity "
        "references hold up to the benchmarks' own calibration and sync. A NEES above its "
        "bound there says the reported sigma does not cover the estimate's distance to that "
        "reference, which includes the reference's own error. Why the target counts NEES + "
        "ref accuracy: the quantity compared is `X - X_ref = (X - X_true) - (X_ref - "
        "X_true)`, whose covariance is the sum of both when the errors are independent; "
        "leaving the reference's out tests the reference as much as the estimate. The "
        "estimate's own sigma is checked without any reference by the split-half column, "
        "by the sets sharing a mount and by the Tango loop below.",
        "",
        "## Notes on the data", "",
        *[f"- {n}" for n in DATA_NOTES], "",
        "## The sets", "",
        "| set | what | reference | correct (README) | must flag | notes |",
        "|---|---|---|---|---|---|",
        *[f"| {e.name} | {e.what} | {e.reference or 'none'} | "
          f"{e.tolerance.text if e.tolerance else '–'} | "
          f"{', '.join(q.text for q in e.required_flags) or '–'} | {e.notes or '–'} |"
          for e in (set_by_name(n) for n in results)],
        "",
    ]
    return "\n".join(lines)


# ----------------------------------------------------------------------------- running
def run_sets(names=None, *, cache_dir=None, progress=None) -> dict:
    """``{name: SetResult}`` for ``names`` (default: every available set, table order)."""
    entries = [set_by_name(n) for n in names] if names else list(SETS)
    out = {}
    for e in entries:
        ok, why = set_available(e)
        if not ok:
            if names:
                raise DataError(f"data set {e.name}: {why}")
            continue
        out[e.name] = run_set(e, cache_dir=cache_dir)
        if progress is not None:
            r = out[e.name]
            progress(f"{e.name}: exit {r.exit_code} {r.verdict} {r.wall_time_s:.1f} s"
                     + (f" ({r.error[:120]})" if r.error else ""))
    if not out:
        raise DataError(f"no data set found under {real_dir()} or {eth_dir()} (set "
                        f"{REAL_ENV} / {ETH_ENV})")
    return out


def write_document(path, names=None, *, command: str) -> tuple[Path, dict]:
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="simcalib_eth_") as cache:
        results = run_sets(names, cache_dir=cache,
                           progress=lambda m: print(m, file=sys.stderr, flush=True))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(markdown(results, command=command,
                             total_time_s=time.perf_counter() - t0))
    return path, results


@dataclass(frozen=True)
class RealDataConfig:
    """``python -m simcalib experiment real_data``: ``sets`` (empty: all available),
    ``output`` folder (writes ``real-data.md``)."""
    sets: tuple[str, ...] = ()
    output: str = "results/real_data"

    def __post_init__(self):
        for n in self.sets:
            set_by_name(n)


@experiment('real_data', config=RealDataConfig,
            description='the regression table on the public real recordings')
def run(cfg: RealDataConfig):
    from simcalib.studies.experiments.common import ExperimentResult, output_dir
    t0 = time.perf_counter()
    out = output_dir(cfg.output)
    cmd = "python -m simcalib experiment real_data" + (
        f" sets=[{','.join(cfg.sets)}]" if cfg.sets else "") + f" output={cfg.output}"
    path, results = write_document(out / "real-data.md", cfg.sets or None, command=cmd)
    s = summarise(results)
    notes = (f"{s.n_ran}/{s.n_sets} exit 0 or 6, {s.n_within_reference}/{s.n_referenced} "
             f"within reference, NEES {s.n_nees_within}/{s.n_nees_sets}",)
    return ExperimentResult("real_data", out, {"md": path}, [], time.perf_counter() - t0,
                            notes, {"results": results})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.real_data",
                                description="Calibrate every public recording with the "
                                "defaults and write the markdown table.")
    p.add_argument("--output", default="docs/real-data.md", help="markdown file to write")
    p.add_argument("--sets", nargs="*", default=None, metavar="NAME",
                   help="only these sets: " + ", ".join(s.name for s in SETS))
    args = p.parse_args(argv)
    cmd = "python -m simcalib.studies.experiments.real_data --output " + args.output + (
        " --sets " + " ".join(args.sets) if args.sets else "")
    from simcalib.errors import ConfigError
    try:
        path, results = write_document(args.output, args.sets or None, command=cmd)
    except (ConfigError, DataError) as exc:
        print(f"simcalib: error: {exc}", file=sys.stderr)
        return exc.exit_code
    s = summarise(results)
    print(f"wrote {path}: {s.n_ran}/{s.n_sets} exit 0 or 6; {s.n_within_reference}/"
          f"{s.n_referenced} within reference; NEES within bound {s.n_nees_within}/"
          f"{s.n_nees_sets}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
