"""The calibration of recorded poses, as a library: the core of ``simcalib calibrate``
(docs/calibrate.md).

:func:`calibrate` reads the two streams (pose files, a two-stream file or a ROS bag), runs
the one estimation path (:func:`simcalib.estimation.path.calibrate_streams`: reading ->
clock offset -> synchronise -> motions -> robust solve -> the covariance checked by the
data) and judges the result in ONE place, :func:`assess`. The options are the typed
dataclass :class:`CalibrateOptions`, built by the config engine: the same value syntax as
``run``, unknown keys rejected with the closest match. :func:`write_outputs` writes
``calibration.json`` (:mod:`simcalib.report.calibration`), ``motions.npz``, the ROS exports
and ``recording.rrd``.

Exit status of an assessment: 0 determined, 6 degenerate or implausible
(:data:`simcalib.errors.EXIT_DEGENERATE`), 5 the solver failed.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from simcalib.config.checks import check_positive, check_range, check_that, set_fields
from simcalib.config.engine import key_help
from simcalib.estimation.common_error import CommonError
from simcalib.estimation.scale import check_scale_b
from simcalib.estimation.verdict import Tolerances
from simcalib.errors import (EXIT_DEGENERATE, EXIT_OK, EXIT_SOLVER, ConfigError, DataError,
                             SolverError, UsageError, unknown_choice)

__all__ = ["CalibrateOptions", "Assessment", "assess", "parse_options", "calibrate",
           "load_prior", "warnings", "write_outputs", "write_ros_exports"]


@dataclass(frozen=True)
class CalibrateOptions:
    """Options of ``simcalib calibrate`` (every key ``key=value``)."""
    a: Path = field(metadata=key_help("pose file of sensor a (X = T_a_b); a two-stream file "
                                      "(easy_handeye, moveit) may give both, then omit b"))
    output: Path = field(metadata=key_help("output directory (created)"))
    overwrite: bool = field(default=False, metadata=key_help(
        "replace an earlier calibration's results in output (else an output holding "
        "calibration.json, results.json or extrinsics.json is refused before any work)"))
    b: Path | None = field(default=None, metadata=key_help("pose file of sensor b"))
    format: str | None = field(default=None, metadata=key_help(
        "format of both files (default: detected); see format_a / format_b"))
    format_a: str | None = field(default=None, metadata=key_help("format of file a"))
    format_b: str | None = field(default=None, metadata=key_help("format of file b"))
    stamps_unit_a: Literal["auto", "s", "ms", "us", "ns"] = field(
        default="auto", metadata=key_help(
            "unit of file a's stamps; auto: seconds, unless their magnitude shows unix time in "
            "ms / us / ns, or both streams tell stamps relative to the start in ms / us / ns "
            "(their spans and steps a unit apart, or a dense motion stepping by seconds): "
            "rescaled and counted as a repair; suspect stamps the data cannot tell are "
            "refused (docs/calibrate.md, Bad input)"))
    stamps_unit_b: Literal["auto", "s", "ms", "us", "ns"] = field(
        default="auto", metadata=key_help("the same for file b"))
    scale_b: float | Literal["auto", "estimate"] = field(default="auto", metadata=key_help(
        "scale of b's translations against a's (b in a's unit times this: a monocular SLAM "
        "track, a wrong target size, other units); auto: estimated from the motions and "
        "used only where it differs from 1 clearly (beyond 3 % and 5 sigma) and explains "
        "the translation misfit (3x); beyond 3x at a ratio of length units, e.g. mm "
        "against m, refused as a unit mismatch; "
        "estimate: always estimated and used; a number: b's translations divided by it "
        "(docs/calibrate.md, Streams of unknown scale)"))
    time_offset: float | Literal["estimate"] = field(default="estimate", metadata=key_help(
        "clock offset t_b - t_a in seconds, or 'estimate'"))
    drift: bool | Literal["auto"] = field(default="auto", metadata=key_help(
        "a linear clock drift between the files' clocks: auto: fitted where the offsets of "
        "contiguous parts of the recording lie on a line that explains their spread "
        "(docs/calibrate.md, Time alignment); true: always fitted; false: one offset"))
    robust: Literal["auto", "ransac", "irls", "none"] = field(default="auto", metadata=key_help(
        "outlier rejection over motions (auto: RANSAC where the motions give minimal sets, "
        "IRLS where they do not, none below 8 motions)"))
    motions: Literal["auto", "stations", "bursts", "spans", "consecutive", "keyframes"] = field(
        default="auto", metadata=key_help(
            "which pose pairs become motions (auto: every/far pair for stamp-paired "
            "stop-and-go data, pairs of stations for several poses a stop (bursts), spans "
            "of 1, 2, 4, 8 x step_s for continuous streams; consecutive: step_s only)"))
    threshold: float | None = field(default=None, metadata=key_help(
        "RANSAC inlier threshold on the screw residual (default: automatic, LMedS)"))
    method: str = field(default="dqopt", metadata=key_help("solver of the final estimate"))
    alpha: float = field(default=1.0, metadata=key_help(
        "weight of translation in the cost, 1/m"))
    prior: str | None = field(default=None, metadata=key_help(
        "prior X: a JSON file (a calibration.json, {\"X\": 4x4} or {\"translation_m\", "
        "\"quaternion_xyzw\"}) or inline [tx,ty,tz,qx,qy,qz,qw] / 16 numbers row-major"))
    prior_weight_rotation: float = field(default=1e-4, metadata=key_help(
        "prior weight a (rotation; small: determined directions keep the data value)"))
    prior_weight_translation: float = field(default=1e-2, metadata=key_help(
        "prior weight b (translation)"))
    invert_a: bool | None = field(default=None, metadata=key_help(
        "force reading file a as inverted (it holds T_sensor_world); default: detected"))
    invert_b: bool | None = field(default=None, metadata=key_help("the same for file b"))
    scalar_first_a: bool | None = field(default=None, metadata=key_help(
        "force reading a's quaternion numbers in the other order; default: detected"))
    scalar_first_b: bool | None = field(default=None, metadata=key_help("the same for file b"))
    mirror_b: bool | None = field(default=None, metadata=key_help(
        "force reading file b as mirrored (a left-handed frame: z -> -z, quaternions "
        "(-qx, -qy, qz, qw)) or not; default: detected where the motion tells"))
    step_s: float = field(default=1.0, metadata=key_help(
        "consecutive motions span this time step, s"))
    min_rotation_deg: float = field(default=2.0, metadata=key_help(
        "motions rotating less are dropped (they carry no information)"))
    max_rotation_deg: float | None = field(default=None, metadata=key_help(
        "motions rotating more are dropped (tracking jumps)"))
    seed: int = field(default=0, metadata=key_help("seed of RANSAC and convention scoring"))
    recording: bool = field(default=True, metadata=key_help("write recording.rrd"))
    common_error: CommonError = field(default_factory=CommonError, metadata=key_help(
        "common_error.rotation_a_deg / translation_a_m / rotation_b_deg / translation_b_m: "
        "the rms of an error common to every pose of a stream in its own frame (a robot's "
        "absolute accuracy), which moves X without a residual: added to sigma when stated"))
    verdict: Tolerances = field(default_factory=Tolerances, metadata=key_help(
        "verdict.tolerance_deg / verdict.tolerance_m: 1-sigma above which a direction is "
        "poorly determined"))
    bag: Path | None = field(default=None, metadata=key_help(
        "a ROS bag (ROS 1 .bag; ROS 2 directory, .mcap or .db3): a and b are then stream "
        "specs, '/tf:PARENT->CHILD' (pose of CHILD in PARENT through the tf tree) or a topic "
        "of PoseStamped, PoseWithCovarianceStamped, Odometry or TransformStamped "
        "(docs/ros.md); list a bag with list_bag=FILE"))
    export: tuple[str, ...] = field(default=(), metadata=key_help(
        "also write X for ROS into output: any of urdf, static_tf, launch, easy_handeye2, "
        "kalibr, e.g. export=[urdf,launch] (docs/ros.md)"))
    frame_a: str | None = field(default=None, metadata=key_help(
        "frame name of sensor a in the exports (default with bag=: from a's spec)"))
    frame_b: str | None = field(default=None, metadata=key_help(
        "frame name of sensor b in the exports (default with bag=: from b's spec)"))
    eye: Literal["in_hand", "on_base"] | None = field(default=None, metadata=key_help(
        "where the camera (b) is: in_hand (a's sensor is the effector: X = T_ee_cam) or "
        "on_base (a read as T_ee_base, e.g. invert_a=true on a T_base_ee file: X = "
        "T_base_cam, metres long by nature, so not flagged implausible; a short X with a "
        "long twin is). Also the easy_handeye2 export's calibration_type, frame_a being "
        "the effector (in_hand) or the base (on_base)"))
    robot_frame: str | None = field(default=None, metadata=key_help(
        "for export=easy_handeye2: the robot's other frame, the base with eye=in_hand or "
        "the effector with eye=on_base (default with bag=: the other end of a's spec; "
        "needed without bag=)"))
    marker_frame: str | None = field(default=None, metadata=key_help(
        "for export=easy_handeye2: the tracking marker frame (default with bag=: the other "
        "end of b's spec; else tracking_marker)"))

    def __post_init__(self):
        self._check_ros()
        from simcalib.importers import available
        from simcalib.solvers import registry
        for key in ("format", "format_a", "format_b"):
            v = getattr(self, key)
            if v is not None and v not in available():
                raise unknown_choice("pose-file format", v, available(), key=key)
        if self.format is not None and (self.format_a or self.format_b):
            raise ConfigError("give format (both files) or format_a / format_b, not both",
                              key="format")
        if self.method not in registry.available():
            raise unknown_choice("method", self.method, registry.available(), key="method")
        if self.prior is not None and not registry.get(self.method).supports_prior:
            raise ConfigError(key="prior", value=self.prior, allowed="used with a method "
                              "that supports a prior (" + ", ".join(
                                  i.name for i in registry.infos() if i.supports_prior) + ")")
        if self.time_offset != "estimate":
            set_fields(self, time_offset=check_range("time_offset", self.time_offset))
        set_fields(self, scale_b=check_scale_b(self.scale_b))
        check_that(not (self.drift is True and self.time_offset != "estimate"), "drift",
                   self.drift, "auto or false when time_offset is given")
        set_fields(self,
                   alpha=check_positive("alpha", self.alpha),
                   step_s=check_positive("step_s", self.step_s),
                   min_rotation_deg=check_range("min_rotation_deg", self.min_rotation_deg,
                                                lo=0.0, hi=180.0),
                   max_rotation_deg=check_range("max_rotation_deg", self.max_rotation_deg,
                                                lo=0.0, hi=180.0, lo_open=True, optional=True),
                   threshold=check_range("threshold", self.threshold, lo=0.0, lo_open=True,
                                         optional=True),
                   prior_weight_rotation=check_positive("prior_weight_rotation",
                                                        self.prior_weight_rotation,
                                                        allow_zero=True),
                   prior_weight_translation=check_positive("prior_weight_translation",
                                                           self.prior_weight_translation,
                                                           allow_zero=True))
        check_that(self.threshold is None or self.robust in ("ransac", "auto"), "threshold",
                   self.threshold, "given only with robust=ransac or auto")
        check_that(self.prior_weight_rotation > 0 or self.prior_weight_translation > 0,
                   "prior_weight_rotation", self.prior_weight_rotation,
                   "> 0 when prior_weight_translation is 0 (omit prior instead)")

    def _check_ros(self):
        if self.export:
            from simcalib.ros.exports import EXPORT_KINDS
        for k in self.export:
            if k not in EXPORT_KINDS:
                raise unknown_choice("export kind", k, EXPORT_KINDS, key="export")
        if self.bag is not None:
            check_that(self.b is not None, "b", self.b,
                       "a stream spec with bag= ('/tf:PARENT->CHILD' or a topic)")
            check_that(not (self.format or self.format_a or self.format_b), "format",
                       self.format or self.format_a or self.format_b, "omitted with bag=")
            for k in ("stamps_unit_a", "stamps_unit_b"):
                check_that(getattr(self, k) == "auto", k, getattr(self, k),
                           "auto with bag= (a bag's stamps are ROS times in seconds)")
        check_that("easy_handeye2" not in self.export or self.eye is not None, "eye",
                   self.eye, "in_hand or on_base with export=easy_handeye2")
        for key in ("frame_a", "frame_b"):
            check_that(not self.export or self.bag is not None
                       or getattr(self, key) is not None, key, getattr(self, key),
                       "given for export= without bag= (frame_a=NAME frame_b=NAME: the "
                       "parent and child of X = T_a_b)")
        if "easy_handeye2" in self.export and self.bag is None and self.robot_frame is None:
            from simcalib.ros.exports import ROBOT_FRAME_NEEDED
            raise ConfigError(key="robot_frame", value=None, allowed=ROBOT_FRAME_NEEDED)

    @property
    def formats(self) -> tuple[str | None, str | None]:
        return (self.format_a or self.format, self.format_b or self.format)


def parse_options(args: list[str]) -> CalibrateOptions:
    """``["a=x.csv", "b=y.csv", "output=out"]`` -> :class:`CalibrateOptions` through the
    config engine (typed values, closest match for unknown keys; :class:`ConfigError`)."""
    from simcalib.config.engine import apply_overrides, build
    for a in args:
        if a.startswith("-"):
            raise UsageError(f"unknown option {a!r}; options: --help, --debug "
                             "(everything else is key=value)")
    try:
        return build(CalibrateOptions, apply_overrides({}, args, CalibrateOptions))
    except ConfigError as exc:      # the engine's key hint names `run --help`
        msg = str(exc).replace("python -m simcalib run --help", "calibrate --help")
        if msg == str(exc):
            raise
        raise type(exc)(msg, key=exc.key) from None


# ---------------------------------------------------------------------------- the prior
def load_prior(spec: str) -> np.ndarray:
    """A 4x4 prior ``X`` from ``spec``: a JSON file (a ``calibration.json`` of this command,
    ``{"X": 4x4}``, ``{"T_a_b": 4x4}`` or ``{"translation_m": [3], "quaternion_xyzw": [4]}``)
    or inline JSON/YAML (``[tx,ty,tz,qx,qy,qz,qw]``, 16 numbers row-major, or a mapping)."""
    import yaml

    from simcalib.geometry import matrix_from_quat, transform_from_rotation_translation
    text = spec.strip()
    where = "prior"
    if not text.startswith(("[", "{")):
        p = Path(text)
        if not p.is_file():
            raise DataError(f"prior {spec!r} is neither a file nor an inline list "
                            "[tx,ty,tz,qx,qy,qz,qw]")
        text, where = p.read_text(), f"prior file {str(p)!r}"
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise DataError(f"{where}: not JSON/YAML ({str(exc).splitlines()[0]})") from None
    if isinstance(data, dict):
        if isinstance(data.get("X"), dict):        # a calibration.json of this command
            data = data["X"]
        if "T_a_b" in data or "X" in data:
            data = data.get("T_a_b", data.get("X"))
        elif "translation_m" in data and "quaternion_xyzw" in data:
            data = list(data["translation_m"]) + list(data["quaternion_xyzw"])
        else:
            raise DataError(f"{where}: expected keys X, T_a_b or translation_m + "
                            f"quaternion_xyzw; received {sorted(data)}")
    try:
        v = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError):
        raise DataError(f"{where}: expected numbers; received {data!r}"[:200]) from None
    if v.size == 7 and v.ndim == 1:
        q = v[3:]
        if not 0.8 < np.linalg.norm(q) < 1.2:
            raise DataError(f"{where}: quaternion {q.tolist()} is not unit (order x,y,z,w)")
        X = transform_from_rotation_translation(matrix_from_quat(q / np.linalg.norm(q)), v[:3])
    elif v.size == 16:
        X = v.reshape(4, 4)
    else:
        raise DataError(f"{where}: expected 7 numbers (t, q_xyzw) or a 4x4 matrix; received "
                        f"shape {v.shape}")
    from simcalib.geometry import check_transforms
    try:
        check_transforms(X[None], "prior X")
    except ValueError as exc:
        raise DataError(f"{where}: {exc}") from None
    return X


# ----------------------------------------------------------------- quality: ONE place
@dataclass(frozen=True)
class Assessment:
    """How far the estimate can be trusted. ``verdict``: ``determined``, ``poorly
    determined``, ``undetermined`` or ``FAILED``; ``std_rot_deg`` / ``std_trans_m``: 1-sigma
    per axis (frame a) or None when not available; ``covariance`` 6x6 (rad, m) or None;
    ``source``: what it was computed from; ``summary``: one line for people;
    ``unverified``: the data were too few to check the model's sigma."""
    verdict: str
    degenerate: bool
    summary: str
    source: str
    std_rot_deg: tuple | None = None
    std_trans_m: tuple | None = None
    covariance: tuple | None = None
    undetermined: tuple = ()       # each flagged direction in words (state and sigma)
    unverified: bool = False
    plausibility: object = None     # simcalib.estimation.plausibility.Plausibility
    #: signs that the result should not be trusted even when X is determined (sentences)
    warnings: tuple = ()
    directions: tuple = ()          # the verdict's flagged Directions
    #: the same directions as records (simcalib.report.directions.direction_record)
    direction_records: tuple = ()

    @property
    def implausible(self) -> bool:
        return self.plausibility is not None and not self.plausibility.plausible

    @property
    def exit_code(self) -> int:
        if self.verdict == "FAILED":
            return EXIT_SOLVER
        return EXIT_DEGENERATE if self.degenerate or self.implausible else EXIT_OK


def assess(r, eye: str | None = None) -> Assessment:
    """The verdict on a calibration ``r`` (:class:`simcalib.estimation.path.
    StreamCalibration`): :func:`simcalib.estimation.verdict.judge` on its solution with the
    reported covariance (the model's, raised to the data's own consistency), and the
    plausibility of X for the caller's ``eye`` (``in_hand``, ``on_base`` or None). A failed
    solve, or one whose uncertainty cannot be computed, is FAILED."""
    from simcalib.estimation.world_jumps import largest_world
    from simcalib.estimation.plausibility import check_plausibility
    from simcalib.estimation.verdict import judge
    solution = r.robust.solution
    if solution is None or not solution.success or not np.isfinite(solution.X).all():
        why = getattr(solution, "solver_message", "") or "no estimate"
        return Assessment("FAILED", True, f"the solver failed: {why}", "solver")
    if solution.uncertainty is None or r.covariance is None:
        return Assessment("FAILED", True, "the residuals of the estimate are not finite; "
                          "no uncertainty", "solver")
    from simcalib.report.directions import direction_record, direction_words
    v = judge(solution, r.covariance, r.covariance_determined, r.consistency, r.weighting)
    records = tuple(direction_record(d) for d in v.directions)
    words = tuple(direction_words(None, d) for d in records)
    fin = lambda vals: tuple(float(x) if math.isfinite(x) else None for x in vals)  # noqa
    source = _source(r.consistency)
    one = largest_world(r.synced)           # the twin needs one world-to-world transform
    plaus = check_plausibility(r.X, r.synced.T_a[one], r.synced.T_b[one], r.conventions, eye,
                               translation_undetermined=not any(
                                   math.isfinite(s) for s in v.std_m))
    reading = reading_ambiguity(r, v.std_deg, v.std_m)
    return Assessment(v.verdict, v.degenerate or reading is not None,
                      "; ".join(words + tuple(v.notes)), source,
                      fin(v.std_deg), fin(v.std_m),
                      tuple(fin(row) for row in np.asarray(r.covariance)), words,
                      v.unverified, plaus, tuple(warnings(r, reading)) + tuple(plaus.warnings),
                      tuple(v.directions), records)


def reading_ambiguity(r, std_deg, std_m) -> str | None:
    """A warning when the files' reading did not clearly win AND the runner-up reading
    moves X by more than 3 reported sigmas (the sigma holds for the reading used only):
    the data then do not determine X, whatever its sigma says (exit 6). None otherwise."""
    conv = r.conventions
    alt = getattr(conv, "runner_up_X", None)
    if conv.clear or alt is None:
        return None
    from simcalib.geometry import rotation_error_rad, rotvec_from_matrix
    d_deg = math.degrees(float(rotation_error_rad(alt, r.X)))
    d_m = float(np.linalg.norm(np.asarray(alt)[:3, 3] - r.X[:3, 3]))
    s_deg = max([x for x in std_deg if math.isfinite(x)], default=math.inf)
    s_m = max([x for x in std_m if math.isfinite(x)], default=math.inf)
    if d_deg <= 3 * s_deg and d_m <= 3 * s_m:
        return None
    alt = np.asarray(alt)
    t_mm = ", ".join(f"{1e3 * x:.1f}" for x in alt[:3, 3])
    rv = ", ".join(f"{x:.2f}" for x in np.degrees(rotvec_from_matrix(alt[:3, :3])))
    return (f"the reading is not told by the data (ratio {conv.ratio:.2f} <= 3) and it "
            f"matters: the runner-up ({conv.runner_up}) gives X {d_deg:.3g} deg / "
            f"{1e3 * d_m:.3g} mm away, beyond 3 sigma (t = [{t_mm}] mm, rotvec [{rv}] deg): "
            "X is undetermined until the reading is forced (invert_a/_b, "
            "scalar_first_a/_b)")


def _source(check) -> str:
    """What the reported sigma was computed from, in a few words."""
    from simcalib.estimation.consistency import PoseConsistency
    if isinstance(check, PoseConsistency):
        if check.covariance is None:
            return "the solver's covariance from the residuals (too few poses to check)"
        return ("the poses' own errors, white and correlated"
                + (", raised to the split-half disagreement" if check.raised else
                   ", checked by the recording's two halves" if check.checked else
                   " (unverified)"))
    return ("the solver's covariance from the residuals"
            + (", raised to a block jackknife of the data" if check is not None
               and check.raised else
               ", checked by a block jackknife" if check is not None and check.checked
               else " (not checked: too few poses)"))


# ---------------------------------------------------------------------- the calibration
def calibrate(opts: CalibrateOptions):
    """Run the calibration for ``opts``; returns ``(StreamCalibration, Assessment)``.
    Raises DataError (bad files) or SolverError (no estimate)."""
    from simcalib.solvers.api import Prior
    from simcalib.estimation.path import calibrate_streams
    from simcalib.importers import read_pose_streams
    fa, fb = opts.formats
    if opts.bag is not None:
        from simcalib.ros.bag import read_bag_streams
        a, b = read_bag_streams(opts.bag, str(opts.a), str(opts.b))
    elif opts.b is None:
        ua, ub = opts.stamps_unit_a, opts.stamps_unit_b
        streams = read_pose_streams(opts.a, fa, stamps_unit=ua if ua == ub != "auto" else "pair")
        if len(streams) != 2:
            from simcalib.importers import FORMATS
            both = [n for n in FORMATS.names() if FORMATS.info(n)["two_streams"]]
            raise DataError(f"{str(opts.a)!r} holds {len(streams)} stream(s); give b=PATH "
                            f"(files of the formats {', '.join(sorted(both))} hold both)")
        a, b = streams
    else:
        from simcalib.estimation.path import read_files
        a, b = read_files(opts.a, opts.b, fa, fb, opts.stamps_unit_a, opts.stamps_unit_b)
    prior = None
    if opts.prior is not None:
        prior = Prior(load_prior(opts.prior), opts.prior_weight_rotation,
                               opts.prior_weight_translation)
    robust_options = {"threshold": opts.threshold} if opts.threshold is not None else {}
    try:
        r = calibrate_streams(a, b, time_offset=opts.time_offset, robust=opts.robust,
                              motions=opts.motions, tolerances=opts.verdict,
                              alpha=opts.alpha, step_s=opts.step_s,
                              min_rotation_deg=opts.min_rotation_deg,
                              max_rotation_deg=opts.max_rotation_deg,
                              invert_a=opts.invert_a, invert_b=opts.invert_b,
                              scalar_first_a=opts.scalar_first_a,
                              scalar_first_b=opts.scalar_first_b, mirror_b=opts.mirror_b,
                              drift=opts.drift,
                              robust_options=robust_options, method=opts.method,
                              prior=prior, seed=opts.seed, common_error=opts.common_error,
                              stamps_unit_a=opts.stamps_unit_a, stamps_unit_b=opts.stamps_unit_b,
                              scale_b=opts.scale_b)
    except (DataError, SolverError):
        raise
    except ValueError as exc:                   # too few motions, no overlap ...
        raise DataError(f"cannot calibrate these streams: {exc}") from None
    return r, assess(r, opts.eye)



# ------------------------------------------------------------------------------ outputs
def write_outputs(opts: CalibrateOptions, r, a: Assessment,
                  solver_kernels: str = "compiled") -> dict:
    """Write calibration.json, motions.npz and recording.rrd into ``opts.output``."""
    from simcalib.report.calibration import format_report, report_dict
    from simcalib.solvers.robust import constraint_errors
    from simcalib.config.files import output_folder
    out = output_folder(opts.output)
    report = report_dict(opts, r, a, solver_kernels)
    if opts.export:
        report["files"]["exports"] = {k: p.name for k, p in write_ros_exports(opts, r).items()}
    (out / "calibration.json").write_text(json.dumps(report, indent=2) + "\n")
    rot, trans = constraint_errors(r.C, r.H, r.X)
    i, j = r.motion_index
    sp = r.synced
    np.savez_compressed(
        out / "motions.npz", C=r.C, H=r.H, time_start_s=sp.time_s[i], time_end_s=sp.time_s[j],
        index_start=i, index_end=j, inlier=r.robust.inlier_mask, weight=r.robust.weights,
        screw_residual=r.robust.residuals, rotation_error_deg=np.degrees(rot),
        translation_error_m=trans, X=r.X, synced_time_s=sp.time_s, synced_T_world_a=sp.T_a,
        synced_T_world_b=sp.T_b, **({} if sp.world is None else {"synced_world": sp.world}))
    if opts.recording:
        from simcalib.report.rerun.calibration import record_calibration
        record_calibration(out / "recording.rrd", r, report, console=format_report(report))
    return report


def write_ros_exports(opts: CalibrateOptions, r) -> dict:
    """The exports ``opts.export`` of ``r.X`` into ``opts.output`` (docs/ros.md); the frames
    come from the bag specs (the sensor end of each, as the conventions read it), overridden
    by frame_a / frame_b (robot_frame / marker_frame for easy_handeye2: without bag= the
    robot frame must be given)."""
    import dataclasses

    from simcalib.ros.exports import ExportFrames, write_exports
    conv = r.conventions
    if opts.bag is not None:
        from simcalib.ros.bag import export_frames
        frames = export_frames(path=opts.bag, spec_a=str(opts.a), spec_b=str(opts.b),
                               invert_a=conv.invert_a, invert_b=conv.invert_b, eye=opts.eye,
                               frame_a=opts.frame_a, frame_b=opts.frame_b,
                               name=Path(opts.output).name or "simcalib")
    else:
        frames = ExportFrames(opts.frame_a, opts.frame_b, eye=opts.eye,
                              name=Path(opts.output).name or "simcalib")
    frames = dataclasses.replace(frames, robot_frame=opts.robot_frame or frames.robot_frame,
                                 marker_frame=opts.marker_frame or frames.marker_frame)
    return write_exports(opts.output, r.X, opts.export, frames)


def warnings(r, reading: str | None = None) -> list[str]:
    """Signs that the result should not be trusted even when X is determined
    (``reading``: the sentence of :func:`reading_ambiguity`, which then replaces the
    general one about the reading)."""
    out = [reading] if reading else []
    out += list(r.summary.get("world_jumps", [])) + list(r.summary.get("station_rows", []))
    out += [f"stream {s.name or s.source}'s stamps go back {s.repairs['stamps_restarted']} "
            "time(s) (two recordings in one file?): only the longest recording in it is used "
            f"({s.repairs['rows_of_other_recordings_dropped']} rows of the others dropped)"
            for s in (r.stream_a, r.stream_b) if s.repairs.get("stamps_restarted")]
    scale = getattr(r, "scale", None)
    if scale is not None and scale.decision == "rescaled" and scale.mode == "auto":
        out.append(f"stream b's translations are not in a's scale: {scale.message}")
    if r.conventions.mirror_b and math.isfinite(r.conventions.mirror_ratio):
        from simcalib.estimation.readings import mirror_sentence
        out.append(mirror_sentence(r.conventions.mirror_ratio))
    if not r.conventions.clear and not reading:
        out.append(f"the reading of the files did not clearly win (ratio "
                   f"{r.conventions.ratio:.2f} <= 3): check the files or force invert_a/_b, "
                   "scalar_first_a/_b")
    peak = r.time_offset.peak_correlation
    if math.isfinite(peak) and peak < 0.5:
        speeds = "angular" if r.time_offset.signal == "rotation" else "translation"
        out.append(f"weak {speeds}-speed correlation (peak r = {peak:.2f})" + (
            " and the data do not tell the offset, so 0 is used: if the clocks differ, give "
            "time_offset=<seconds>" if r.time_offset.decision == "zero"
            else ": the offset may be wrong"))
    elif r.time_offset.decision == "zero" and not math.isfinite(r.time_offset.uncertainty_s):
        out.append("the data do not bound the clock offset, so 0 is used: if the clocks "
                   "differ, give time_offset=<seconds>")
    if r.robust.inlier_fraction < 0.5:
        out.append(f"only {r.robust.inlier_fraction:.0%} of the motions are inliers")
    return out
