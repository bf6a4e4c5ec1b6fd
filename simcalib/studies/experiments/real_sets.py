"""The public real recordings of the real-data regression table: which sets
(:data:`SETS`, each with its tolerance, required flags and notes), where their files are
(``$SIMCALIB_REAL_DIR`` / ``$SIMCALIB_ETH_DIR``, the ETH zips unpacked into a cache), and
their reference ``X = T_a_b`` (a file, the README, identity or OpenCV on the files).
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.errors import DataError

__all__ = ["REAL_ENV", "ETH_ENV", "OPENCV_MAX_POSES", "NEES_TARGET_SHARE", "AGREEMENT_SIGMA",
           "ALL_AXES", "ROTATION_ONLY", "RequiredFlag", "Tolerance", "RealSet", "DATA_NOTES",
           "CROSS_SET_PAIRS", "STATED_AGREEMENT", "LOOPS", "set_by_name", "real_dir",
           "eth_dir", "set_available", "set_paths", "Reference", "read_reference_file",
           "read_readme_reference", "read_tum", "load_reference", "reference_tolerance"]


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
