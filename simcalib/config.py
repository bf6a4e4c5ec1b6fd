"""Typed scenario configuration: frozen dataclasses loaded from YAML, dotted overrides.

A scenario file (``scenarios/NAME.yaml``) is a partial :class:`ScenarioConfig`; every key
it leaves out takes the dataclass default. Command-line overrides are dotted keys with
typed values::

    seed=3 output=runs/x noise.sigma_r_deg=1.0 solvers=[dqopt,daniilidis] source=noisy
    alpha=0.5 camera.width=1280

A key may be abbreviated to any unique suffix of its full dotted path (``sigma_r_deg`` for
``noise.sigma_r_deg``); ``camera.*`` sets both cameras. An unknown key, an ambiguous
abbreviation or a bad value raises :class:`ConfigError` (a ``ValueError``) naming the key,
what was received and what is allowed (with the closest match) — before any work starts.

The generic machinery (:func:`build`, :func:`to_dict`, :func:`leaf_paths`,
:func:`apply_overrides`) works on any frozen dataclass tree, so the stage configs owned by
other modules (``WorldConfig``, ``VisionConfig``, ``SyntheticConfig``) are composed, not
copied. The same engine builds the experiments' configs (``Table2Config`` …) and the cells
of a sweep: :func:`load_config` (one config) and :func:`load_configs` (many override sets
over one base, every cell validated before any work) are cheap (the key tables are cached).

Lists have one syntax everywhere (runs, experiments, sweeps): ``alpha=[0.1,1,10]``,
``solvers=[dqopt,daniilidis]``; a single value for a list key is a one-element list.

Why one hand-written coercer rather than pydantic v2: the schemas are plain frozen
dataclasses that library code builds directly from Python (stage configs, experiment
configs, results), so a small coercer over ``typing`` hints (:func:`_coerce`, one helper
per kind of type) keeps them import-light and gives exactly the messages, suffix keys and
aliases the CLI needs, where pydantic would add a second model layer over every
dataclass. Range checks live in each dataclass's
``__post_init__``, written with the helpers of :mod:`simcalib.checks`; every error is a
:class:`simcalib.errors.ConfigError` naming the full dotted key.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

__all__ = [
    "ConfigError",
    "load_configs",
    "resolve_key",
    "resolve_keys",
    "NoiseConfig",
    "PairingConfig",
    "PriorConfig",
    "RecordingConfig",
    "ScenarioConfig",
    "apply_overrides",
    "build",
    "describe_keys",
    "leaf_paths",
    "list_scenarios",
    "load_config",
    "load_scenario_data",
    "parse_overrides",
    "scenario_dir",
    "scenario_path",
    "to_dict",
]


from simcalib.checks import (check_in, check_int, check_names, check_positive, check_range,
                             check_that, check_vector, set_fields)
from simcalib.errors import ConfigError, did_you_mean, unknown_choice


# ----------------------------------------------------------------- composed sections
def _placeholder(name: str, module: str):
    """Stand-in section when a stage module is not installed (no keys accepted)."""
    cls = dataclasses.make_dataclass(name, [], frozen=True)
    cls.__doc__ = f"({module} is not available in this installation)"
    cls._simcalib_missing = module
    return cls


try:  # the simulated world (issue 4)
    from simcalib.world import WorldConfig
except ImportError:  # pragma: no cover - only while the world branch is missing
    WorldConfig = _placeholder("WorldConfig", "simcalib.world")
try:  # the visual pose source (issue 4)
    from simcalib.vision import VisionConfig
except ImportError:  # pragma: no cover
    VisionConfig = _placeholder("VisionConfig", "simcalib.vision")
from simcalib.estimation.config import EstimationConfig  # noqa: E402
from simcalib.sources.corruption import OutliersConfig  # noqa: E402  (issue 10 sections)
from simcalib.sources.selection import StreamsConfig  # noqa: E402
from simcalib.world.robot_error import RobotConfig  # noqa: E402

try:  # the synthetic generator of appendix D.2 (issue 3)
    from simcalib.synthetic import SyntheticConfig
except ImportError:  # pragma: no cover
    SyntheticConfig = _placeholder("SyntheticConfig", "simcalib.synthetic")


def _doc(text: str) -> dict:
    return {"help": text}


@dataclass(frozen=True)
class NoiseConfig:
    """Pose noise of the ``noisy`` source (paper eq. 38), applied to each camera's poses."""
    sigma_r_deg: float = field(default=0.57, metadata=_doc(
        "rotation noise: angle ~ N(0, sigma_r^2) about a uniform axis, degrees"))
    sigma_t_m: float = field(default=0.01, metadata=_doc(
        "translation noise per axis ~ N(0, sigma_t^2), metres"))

    def __post_init__(self):
        set_fields(self,
                   sigma_r_deg=check_positive("sigma_r_deg", self.sigma_r_deg, allow_zero=True),
                   sigma_t_m=check_positive("sigma_t_m", self.sigma_t_m, allow_zero=True))


@dataclass(frozen=True)
class PairingConfig:
    """How the two cameras' pose streams become relative motions ``(C_i, H_i)``.

    Frames are matched by timestamp (mutual nearest neighbours). Pairs are datapoints
    ``(k, k + step)`` of the matched sequence. The pre-filter of the paper's appendix D.1
    drops datapoints whose two timestamps differ by more than ``max_time_diff_s`` and pairs
    in which either camera moved more than ``max_translation_m`` or ``max_rotation_deg``.
    ``mode=random`` then draws ``n_pairs`` of the surviving pairs at random (appendix D).
    """
    mode: Literal["consecutive", "random"] = field(default="consecutive", metadata=_doc(
        "consecutive: every surviving pair; random: draw n_pairs of them"))
    step: int = field(default=1, metadata=_doc(
        "pair matched datapoint k with k + step"))
    n_pairs: int = field(default=100, metadata=_doc(
        "random mode: number of pairs drawn (without replacement when enough exist)"))
    prefilter: bool = field(default=True, metadata=_doc(
        "apply the appendix D.1 pre-filter (the three thresholds below)"))
    max_time_diff_s: float = field(default=0.1, metadata=_doc(
        "drop datapoints whose two camera timestamps differ by more than this, seconds"))
    max_translation_m: float = field(default=0.10, metadata=_doc(
        "drop pairs where a camera moved more than this, metres"))
    max_rotation_deg: float = field(default=11.5, metadata=_doc(
        "drop pairs where a camera rotated more than this, degrees"))

    def __post_init__(self):
        set_fields(self, step=check_int("step", self.step, lo=1),
                   n_pairs=check_int("n_pairs", self.n_pairs, lo=2),
                   **{name: check_range(name, getattr(self, name), lo=0.0, lo_open=True,
                                        finite=False)   # inf disables a threshold
                      for name in ("max_time_diff_s", "max_translation_m",
                                   "max_rotation_deg")})


@dataclass(frozen=True)
class PriorConfig:
    """The prior of the paper's eqs. 26–29: a nominal extrinsic with weights ``a`` (rotation)
    and ``b`` (translation). Each method in ``methods`` is run a second time with the prior
    and reported as ``<method>+prior``.

    The nominal extrinsic is either given (``translation_m`` and ``rotvec_deg``) or, by
    default, the true ``X`` perturbed by ``rotation_error_deg`` about a random axis and
    ``translation_error_m`` in a random direction — a CAD value as a user would know it.
    """
    enabled: bool = field(default=False, metadata=_doc("run the methods below with the prior"))
    methods: tuple[str, ...] = field(default=("dqopt",), metadata=_doc(
        "methods run a second time with the prior"))
    a: float = field(default=1e-4, metadata=_doc(
        "weight of the rotation prior (relative to the data cost: small, so determined "
        "directions keep the data value)"))
    b: float = field(default=1e-2, metadata=_doc(
        "weight of the translation prior (the undetermined translation takes its value)"))
    rotation_error_deg: float = field(default=2.0, metadata=_doc(
        "error of the simulated nominal extrinsic's rotation, degrees"))
    translation_error_m: float = field(default=0.02, metadata=_doc(
        "error of the simulated nominal extrinsic's translation, metres"))
    translation_m: tuple[float, float, float] | None = field(default=None, metadata=_doc(
        "explicit nominal translation of X (metres); with rotvec_deg"))
    rotvec_deg: tuple[float, float, float] | None = field(default=None, metadata=_doc(
        "explicit nominal rotation of X (axis-angle, degrees); with translation_m"))

    def __post_init__(self):
        set_fields(self, a=check_positive("a", self.a), b=check_positive("b", self.b),
                   rotation_error_deg=check_positive("rotation_error_deg",
                                                     self.rotation_error_deg, allow_zero=True),
                   translation_error_m=check_positive("translation_error_m",
                                                      self.translation_error_m, allow_zero=True),
                   methods=check_names("methods", self.methods))
        for name in ("translation_m", "rotvec_deg"):
            if getattr(self, name) is not None:
                set_fields(self, **{name: check_vector(name, getattr(self, name))})
        check_that((self.translation_m is None) == (self.rotvec_deg is None), "translation_m",
                   self.translation_m, "given together with rotvec_deg (or neither, for a "
                   "perturbed true X)")


@dataclass(frozen=True)
class RecordingConfig:
    """The rerun recording (``recording.rrd`` in the run directory)."""
    enabled: bool = field(default=True, metadata=_doc("write recording.rrd"))
    jpeg_quality: int = field(default=70, metadata=_doc("JPEG quality of logged images"))
    max_images: int = field(default=150, metadata=_doc(
        "at most this many images per camera are logged (evenly subsampled)"))
    background: bool = field(default=True, metadata=_doc(
        "write it from a worker process, so rerun's import and the logging overlap the run "
        "(a process that has imported rerun already logs in-process)"))

    def __post_init__(self):
        set_fields(self, jpeg_quality=check_int("jpeg_quality", self.jpeg_quality, lo=1, hi=100),
                   max_images=check_int("max_images", self.max_images, lo=0))


@dataclass(frozen=True)
class VerdictConfig:
    """When an estimate is trusted (issue 9): a direction of X whose predicted 1-sigma
    exceeds a tolerance is "poorly determined" (``Solution.verdict``), and the curve of
    error and predicted sigma against the number of motions used (``convergence``)."""
    tolerance_deg: float = field(default=1.0, metadata=_doc(
        "1-sigma rotation tolerance, degrees (above it: poorly determined)"))
    tolerance_m: float = field(default=0.01, metadata=_doc(
        "1-sigma translation tolerance, metres (above it: poorly determined)"))
    convergence_points: int = field(default=10, metadata=_doc(
        "solve on the first k motions for this many log-spaced k (0: no curve)"))

    def __post_init__(self):
        set_fields(self,
                   tolerance_deg=check_positive("tolerance_deg", self.tolerance_deg),
                   tolerance_m=check_positive("tolerance_m", self.tolerance_m),
                   convergence_points=check_int("convergence_points",
                                                self.convergence_points, lo=0, hi=100))


SOURCES = ("ground_truth", "noisy", "aruco", "robot_fk", "fixed_board")
KINDS = ("sim", "synthetic")


@dataclass(frozen=True)
class ScenarioConfig:
    """One end-to-end run: world -> pose streams -> motion pairs -> solvers -> evaluation."""
    scenario: str = field(default="custom", metadata=_doc("scenario name"))
    description: str = field(default="", metadata=_doc("one-line description"))
    kind: Literal["sim", "synthetic"] = field(default="sim", metadata=_doc(
        "sim: MuJoCo world (world.*, vision.*); synthetic: paper appendix D.2 (synthetic.*)"))
    source: Literal["ground_truth", "noisy", "aruco", "robot_fk", "fixed_board"] = field(
        default="aruco", metadata=_doc("pose source of both streams (unless streams.a/b.source "
                                       "says otherwise)"))
    seed: int = field(default=0, metadata=_doc("seed of every random draw of the run"))
    output: str | None = field(default=None, metadata=_doc(
        "run directory (default runs/<scenario>-<timestamp>)"))
    overwrite: bool = field(default=False, metadata=_doc(
        "replace an earlier run's results in output (else an output holding results.json "
        "or extrinsics.json is refused before any work)"))
    solvers: tuple[str, ...] = field(default=("dqopt", "dq2ndord", "dqconvrlx", "dq2steps",
                                              "daniilidis"), metadata=_doc(
        "methods to run (python -m simcalib list)"))
    alpha: Literal["auto"] | float | tuple[float, ...] = field(default="auto", metadata=_doc(
        "translation weight alpha (1/m): auto (chosen from the data: "
        "simcalib.solvers.diagnostics.uncertainty.choose_alpha), a number, or a list (a "
        "sweep: every alpha is reported; the headline stays the data-chosen alpha and the "
        "list's alpha best against the ground truth is reported beside it as oracle_alpha)"))
    workers: int = field(default=2, metadata=_doc("parallel render workers"))
    progress: bool = field(default=True, metadata=_doc("show progress bars"))
    world: WorldConfig = field(default_factory=WorldConfig, metadata=_doc("simulated world"))
    vision: VisionConfig = field(default_factory=VisionConfig, metadata=_doc(
        "visual (ArUco) pose source"))
    synthetic: SyntheticConfig = field(default_factory=SyntheticConfig, metadata=_doc(
        "synthetic generator"))
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    pairing: PairingConfig = field(default_factory=PairingConfig)
    prior: PriorConfig = field(default_factory=PriorConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    streams: StreamsConfig = field(default_factory=StreamsConfig, metadata=_doc(
        "per-stream pose sources (a = cam_a, b = cam_b)"))
    robot: RobotConfig = field(default_factory=RobotConfig, metadata=_doc(
        "arm kinematic error and encoders (robot_fk)"))
    outliers: OutliersConfig = field(default_factory=OutliersConfig, metadata=_doc(
        "injected outliers with ground-truth labels"))
    verdict: VerdictConfig = field(default_factory=VerdictConfig, metadata=_doc(
        "tolerances of the degeneracy verdict and the convergence curve"))
    estimation: EstimationConfig = field(default_factory=EstimationConfig, metadata=_doc(
        "streams -> motions: the paper's pairing, or calibrate's recorded-data path"))

    def __post_init__(self):
        set_fields(self, seed=check_int("seed", self.seed, lo=0),
                   workers=check_int("workers", self.workers, lo=1))
        if self.kind == "synthetic" and self.source in ("aruco", "robot_fk", "fixed_board"):
            raise ConfigError(f"source={self.source} needs a simulated world (kind=sim); a "
                              "synthetic scenario allows source=ground_truth or source=noisy",
                              key="source", value=self.source)
        for key in ("a", "b"):
            name = getattr(self.streams, key).source
            check_in(f"streams.{key}.source", name, SOURCES, optional=True)
            check_that(name is None or self.kind == "sim", f"streams.{key}.source", name,
                       "null in a synthetic scenario (it measures with its own source); "
                       "per-stream sources apply to simulated worlds (kind=sim)")
        set_fields(self, solvers=check_names("solvers", self.solvers))
        if isinstance(self.alpha, (tuple, list)):
            check_that(len(self.alpha) > 0, "alpha", list(self.alpha),
                       "a number > 0 or a non-empty list of them")
            set_fields(self, alpha=tuple(
                check_positive(f"alpha[{i}]", a) for i, a in enumerate(self.alpha)))
        elif self.alpha != "auto":
            set_fields(self, alpha=check_positive("alpha", self.alpha))
        _check_solver_names(self.solvers, "solvers")
        if self.prior.enabled:
            _check_solver_names(self.prior.methods, "prior.methods")
            from simcalib.solvers import registry
            no_prior = [m for m in self.prior.methods if not registry.get(m).supports_prior]
            if no_prior:
                ok = [i.name for i in registry.infos() if i.supports_prior]
                raise ConfigError(f"prior.methods: {', '.join(no_prior)} cannot use a prior; "
                                  f"methods with a prior: {', '.join(ok)}",
                                  key="prior.methods", value=list(self.prior.methods))
        if self.kind == "synthetic" and not getattr(type(self.synthetic), "_simcalib_missing",
                                                    None):
            self._sync_synthetic_noise()
        missing = getattr(type(self.world if self.kind == "sim" else self.synthetic),
                          "_simcalib_missing", None)
        if missing:
            raise ConfigError(f"kind={self.kind} needs {missing}, which is not available "
                              "in this installation", key="kind", value=self.kind)
        if self.kind == "sim" and self.source == "aruco" and getattr(
                type(self.vision), "_simcalib_missing", None):
            raise ConfigError("source=aruco needs simcalib.vision, which is not available "
                              "in this installation", key="source", value=self.source)
        if self.kind == "sim":
            _check_outdoor_source(self)
            _check_path_feasible(self)

    def _sync_synthetic_noise(self):
        """``noise.*`` is the one place measurement noise is set: the synthetic generator's
        ``sigma_r_rad``/``sigma_t_m`` follow it (zero for ``source=ground_truth``); setting
        them to something else is a conflict."""
        syn = self.synthetic
        base = type(syn)()
        if self.source == "ground_truth":
            want_r, want_t = 0.0, 0.0
        else:
            want_r, want_t = math.radians(self.noise.sigma_r_deg), self.noise.sigma_t_m
        for name, want in (("sigma_r_rad", want_r), ("sigma_t_m", want_t)):
            have = getattr(syn, name)
            if have != getattr(base, name) and not math.isclose(have, want, rel_tol=1e-12,
                                                                 abs_tol=1e-15):
                raise ConfigError(f"synthetic.{name}={have} conflicts with noise.* "
                                  f"(the measurement noise of every source): set "
                                  f"noise.sigma_r_deg / noise.sigma_t_m instead",
                                  key=f"synthetic.{name}", value=have)
        object.__setattr__(self, "synthetic", dataclasses.replace(
            syn, sigma_r_rad=want_r, sigma_t_m=want_t))

    @property
    def alphas(self) -> tuple[float, ...]:
        """The alphas given in the config (empty for ``alpha: auto``)."""
        if self.alpha == "auto":
            return ()
        return tuple(self.alpha) if isinstance(self.alpha, tuple) else (float(self.alpha),)

    @property
    def is_sweep(self) -> bool:
        return isinstance(self.alpha, tuple) and len(self.alpha) > 1


def _check_solver_names(names: Sequence[str], key: str) -> None:
    from simcalib.solvers import registry
    valid = registry.available()
    for name in names:
        if name not in valid:
            raise unknown_choice("method", name, valid, key=key)


def _check_outdoor_source(cfg: "ScenarioConfig") -> None:
    """An outdoor platform (``car``) has no marker field: no ArUco source."""
    if cfg.source != "aruco" or getattr(type(cfg.world), "_simcalib_missing", None):
        return
    from simcalib.world.platforms import get_platform
    if get_platform(cfg.world.platform).info.outdoor:
        raise ConfigError(f"source=aruco needs a marker field, and platform "
                          f"{cfg.world.platform!r} drives outdoors at car scale where the "
                          "simulated world has none; use source=noisy (realistic pose noise "
                          "via noise.*) or source=ground_truth", key="source",
                          value=cfg.source)


def _check_path_feasible(cfg: "ScenarioConfig") -> None:
    """Reject, before any work, a world whose path moves too far between frames for the
    pairing pre-filter to keep two motions.

    Paths are defined in cycles per run, so a shorter ``world.duration_s`` (or a lower
    ``fps``) compresses the whole path: the motion between paired frames grows as
    ``cycles / (duration_s * fps)``. Both cameras' paths are predicted from the scripted
    path (:func:`_surviving_pairs`) and the pairs within ``pairing.max_rotation_deg`` /
    ``pairing.max_translation_m`` counted, allowing for the pose source's errors (a
    measured motion may look smaller than the true one): only a configuration that
    surely fails is rejected; a marginal one still runs.
    The message names the shortest duration that passes."""
    world, pairing = cfg.world, cfg.pairing
    if getattr(type(world), "_simcalib_missing", None) or not pairing.prefilter:
        return
    if world.platform == "car":   # the physics sets the car's speed, not the path's clock
        return
    if math.isinf(pairing.max_translation_m) and math.isinf(pairing.max_rotation_deg):
        return
    import numpy as np
    margins = _pose_margins(cfg)
    survivors = _surviving_pairs(world, pairing, world.duration_s, margins)
    if survivors >= 2:
        return
    duration = math.nan
    for k in range(1, 40):   # the shortest whole number of seconds found to work
        candidate = float(math.ceil(world.duration_s * 1.25 ** k))
        if candidate <= 3600.0 and _surviving_pairs(world, pairing, candidate, margins) >= 2:
            duration = candidate
            break
    suggestion = (f"world.duration_s >= {duration:g} at fps={world.fps:g}"
                  if np.isfinite(duration) else "a slower path")
    raise ConfigError(
        f"world.duration_s={world.duration_s:g} (fps={world.fps:g}) compresses path "
        f"{world.path!r} (defined in cycles per run) so much that at most {survivors} frame "
        f"pair(s) can stay within pairing.max_translation_m={pairing.max_translation_m:g} and "
        f"pairing.max_rotation_deg={pairing.max_rotation_deg:g}; at least 2 are needed. "
        f"Use {suggestion}, fewer world.path_params.cycles, or relax pairing.*",
        key="world.duration_s", value=world.duration_s)


#: Rig mount in the platform's target frame (models/cart.xml site ``rig_mount``: 1.10 m
#: above and 0.16 m ahead of the cart base, rig +z = forward); the arm's target frame IS
#: its rig mount (simcalib.world.scene). Rig frame in the world at yaw 0: +z = world +x,
#: +y = world -z, +x = world -y (scene.R_WORLD_RIG_FORWARD).
_R_FORWARD = ((0.0, 0.0, 1.0), (-1.0, 0.0, 0.0), (0.0, -1.0, 0.0))
_CART_MOUNT_M = (0.16, 0.0, 1.10)


#: How far a measured relative motion may fall below the true one for each pose source
#: (translation m, rotation deg): ``noisy`` -> 4 sigma of the difference of two noisy
#: poses; ``aruco`` -> 1 cm / 0.5°, about twice the p95 visual pose error of the default
#: world (docs/vision.md).
def _pose_margins(cfg) -> tuple[float, float]:
    if cfg.source == "noisy":
        k = 4.0 * math.sqrt(2.0)
        return k * cfg.noise.sigma_t_m * math.sqrt(3.0), k * cfg.noise.sigma_r_deg
    if cfg.source == "aruco":
        return 0.01, 0.5
    return 0.0, 0.0


def _surviving_pairs(world, pairing, duration_s: float, margins=(0.0, 0.0)) -> int:
    """Pairs of frames ``pairing.step`` apart that the pre-filter may keep, predicted
    from the scripted path (pure numpy, no scene): both cameras' poses are the target
    path composed with the rig mount and the rig; perturbations and timing jitter are
    left out. ``margins`` (m, deg) widen the thresholds by what pose errors can take off
    a measured motion, so only pairs that are surely dropped are not counted."""
    import numpy as np
    from simcalib.world.paths import compose_path, sample_path
    n = min(int(math.floor(duration_s * world.fps + 1e-9)) + 1, 20001)
    s = pairing.step
    if n <= s:
        return 0
    t = np.arange(n, dtype=np.float64) / world.fps
    R_fwd = np.array(_R_FORWARD)
    T_home, T_target_mount = np.eye(4), np.eye(4)
    if world.platform == "arm":
        T_home[:3, :3] = R_fwd
    else:
        T_target_mount[:3, :3] = R_fwd
        T_target_mount[:3, 3] = _CART_MOUNT_M
    T_target = compose_path(T_home, sample_path(world.path, world.platform, t, duration_s,
                                                world.path_params))
    T_cam_a = T_target @ T_target_mount @ world.rig.T_rig_cam_a()
    keep = np.ones(n - s, dtype=bool)
    for T in (T_cam_a, T_cam_a @ world.rig.T_a_b()):
        T0, T1 = T[:-s], T[s:]
        R_rel = np.einsum("nji,njk->nik", T0[:, :3, :3], T1[:, :3, :3])
        cos = np.clip((np.trace(R_rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
        keep &= np.degrees(np.arccos(cos)) <= pairing.max_rotation_deg + margins[1]
        keep &= (np.linalg.norm(T1[:, :3, 3] - T0[:, :3, 3], axis=1)
                 <= pairing.max_translation_m + margins[0])
    return int(keep.sum())


# --------------------------------------------------------------------- type handling
def _hints(cls) -> dict:
    try:
        return typing.get_type_hints(cls)
    except Exception:  # pragma: no cover - unresolvable annotations: fall back to raw
        return {f.name: f.type for f in dataclasses.fields(cls)}


def _type_name(tp) -> str:
    origin = typing.get_origin(tp)
    if origin is Literal:
        return " | ".join(repr(a) for a in typing.get_args(tp))
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_type_name(a) for a in typing.get_args(tp))
    if origin in (tuple, list):
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"list of {_type_name(args[0])}"
        if args:
            return "[" + ", ".join(_type_name(a) for a in args) + "]"
        return "list"
    if tp is type(None):
        return "null"
    if dataclasses.is_dataclass(tp):
        return "section"
    return getattr(tp, "__name__", str(tp))


def _fail(path: str, value, expected: str, extra: str = "") -> ConfigError:
    from simcalib.errors import ConfigTypeError
    return ConfigTypeError(key=path, value=value, allowed=expected, hint=extra)


def _coerce(value, tp, path: str, default=dataclasses.MISSING):
    """Convert a YAML/override value to the annotated type ``tp`` or raise ConfigError."""
    if tp is Any or tp is object:
        return value
    origin = typing.get_origin(tp)
    if dataclasses.is_dataclass(tp):
        return _coerce_section(value, tp, path, default)
    if origin is Literal:
        return _coerce_choice(value, typing.get_args(tp), path)
    if origin in (typing.Union, types.UnionType):
        return _coerce_union(value, tp, path)
    if origin in (tuple, list):
        return _coerce_typed_sequence(value, tp, path)
    if tp in (tuple, list):  # unparametrised sequence: a scalar is a one-element list
        return _coerce_bare_sequence(value, tp)
    if origin is dict or tp is dict:
        return _coerce_dict(value, path)
    return _coerce_scalar(value, tp, path)


def _coerce_section(value, tp, path: str, default):
    """A nested dataclass section: an instance of ``tp`` as is, else built from a mapping."""
    if dataclasses.is_dataclass(value) and isinstance(value, tp):
        return value
    if not isinstance(value, Mapping):
        raise _fail(path, value, f"a mapping of the keys of section {path!r}")
    return build(tp, value, path=path, base=_custom_base(tp, default))


def _coerce_choice(value, choices: tuple, path: str):
    """A ``Literal`` leaf: one of ``choices``, else an error naming the closest one."""
    if value in choices:
        return value
    opts = [str(a) for a in choices]
    raise ConfigError(f"{path}: invalid value {value!r}{did_you_mean(value, opts)}; "
                      f"allowed: {', '.join(opts)}", key=path, value=value)


def _coerce_union(value, tp, path: str):
    """A union leaf (``X | None``, ``'auto' | float | list``): the first member accepting it."""
    args = typing.get_args(tp)
    if value is None:
        if type(None) in args:
            return None
        raise _fail(path, value, _type_name(tp))
    errors = []
    for a in _union_members_in_order(value, args):
        try:
            return _coerce(value, a, path)
        except ConfigError as exc:
            errors.append(str(exc))
    if len(errors) == 1:
        raise ConfigError(errors[0])
    raise _fail(path, value, _type_name(tp))


def _union_members_in_order(value, args: tuple) -> list:
    """Non-null union members to try: list types first for a list value, else scalars first."""
    non_none = [a for a in args if a is not type(None)]
    seq = [a for a in non_none if typing.get_origin(a) in (tuple, list)]
    scalar = [a for a in non_none if a not in seq]
    return (seq + scalar) if isinstance(value, (list, tuple)) else (scalar + seq)


def _as_items(value):
    """``value`` itself when a list or tuple, else a one-element list (a string is a scalar)."""
    if isinstance(value, str) or not isinstance(value, (list, tuple)):
        return [value]  # a scalar for a list field: a one-element list
    return value


def _coerce_typed_sequence(value, tp, path: str):
    """A ``tuple[...]``/``list[...]`` leaf: ``[X, ...]`` any length, else one value per arg."""
    args = typing.get_args(tp)
    given, value = value, _as_items(value)
    if len(args) == 2 and args[1] is Ellipsis:
        out = [_coerce(v, args[0], f"{path}[{i}]") for i, v in enumerate(value)]
    elif args:
        if len(value) != len(args):
            raise _fail(path, given, f"a list of {len(args)} values "
                                     f"({_type_name(tp)})")
        out = [_coerce(v, a, f"{path}[{i}]") for i, (v, a) in enumerate(zip(value, args))]
    else:
        out = list(value)
    return tuple(out) if typing.get_origin(tp) is tuple else out


def _coerce_bare_sequence(value, tp):
    """An unparametrised ``tuple``/``list`` leaf: its items unchecked, a scalar as one item."""
    seq = list(_as_items(value))
    return tuple(seq) if tp is tuple else seq


def _coerce_dict(value, path: str) -> dict:
    """A ``dict`` leaf: any mapping, copied to a plain dict."""
    if not isinstance(value, Mapping):
        raise _fail(path, value, "a mapping")
    return dict(value)


def _coerce_scalar(value, tp, path: str):
    """A plain-class leaf: bool, int, float, str, Path or any other class (called on it)."""
    if tp is bool:
        return _coerce_bool(value, path)
    if tp is int:
        return _coerce_int(value, path)
    if tp is float:
        return _coerce_float(value, path)
    if tp is str:
        return _coerce_str(value, path)
    if tp is Path:
        return _coerce_path(value, path)
    if isinstance(tp, type):
        return _coerce_instance(value, tp, path)
    return value


def _coerce_bool(value, path: str) -> bool:
    """A ``bool`` leaf: a bool or true/false, yes/no, on/off (any case)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str) and value.lower() in ("true", "false", "yes", "no", "on", "off"):
        return value.lower() in ("true", "yes", "on")
    raise _fail(path, value, "a boolean (true or false)")


def _coerce_int(value, path: str) -> int:
    """An ``int`` leaf: an int (not a bool), an integral float or an integer's text."""
    if isinstance(value, bool):
        raise _fail(path, value, "an integer")
    if isinstance(value, int):
        return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, str):
        try:
            return int(value.strip())
        except ValueError:
            pass
    raise _fail(path, value, "an integer")


def _coerce_float(value, path: str) -> float:
    """A ``float`` leaf: a number (not a bool) or a number's text, never NaN."""
    if isinstance(value, bool):
        raise _fail(path, value, "a number")
    if isinstance(value, (int, float)):
        out = float(value)
    elif isinstance(value, str):
        try:
            out = float(value.strip())
        except ValueError:
            raise _fail(path, value, "a number") from None
    else:
        raise _fail(path, value, "a number")
    if math.isnan(out):
        raise _fail(path, value, "a number (not NaN)")
    return out


def _coerce_str(value, path: str) -> str:
    """A ``str`` leaf: a string, or a number (not a bool) as its text."""
    if isinstance(value, str):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return str(value)
    raise _fail(path, value, "a string")


def _coerce_path(value, path: str) -> Path:
    """A ``Path`` leaf: a string or a path."""
    if isinstance(value, (str, Path)):
        return Path(value)
    raise _fail(path, value, "a path")


def _coerce_instance(value, tp: type, path: str):
    """A leaf of any other class: an instance as is, else ``tp(value)``."""
    if isinstance(value, tp):
        return value
    try:
        return tp(value)
    except Exception:
        raise _fail(path, value, _type_name(tp)) from None


def _custom_base(tp, default):
    """``default`` when it differs from ``tp()`` (a customised section default whose values
    must be kept), else ``None``: fields then take their declared defaults — not values a
    section's ``__post_init__`` resolved (e.g. a platform chosen from the default path)."""
    if not dataclasses.is_dataclass(default) or isinstance(default, type):
        return None
    try:
        return None if default == tp() else default
    except Exception:
        return default


def _unknown_key(key: str, path: str, valid: Sequence[str]) -> ConfigError:
    full = f"{path}.{key}" if path else key
    hint = did_you_mean(key, valid, cutoff=0.5, prefix=path + "." if path else "")
    where = f"section {path!r}" if path else "the top level"
    return ConfigError(f"unknown config key {full!r}{hint}; valid keys in {where}: "
                       f"{', '.join(valid) if valid else '(none)'}", key=full)


def build(cls, data: Mapping | None = None, *, path: str = "", base=None):
    """Build the frozen dataclass ``cls`` from a (partial) mapping, recursively.

    Keys not in ``data`` take the value of ``base`` (a ``cls`` instance) or the field
    default. Unknown keys and bad values raise :class:`ConfigError` naming the full
    dotted key; a ``ValueError``/``TypeError`` raised by a section's own validation is
    re-raised as ``ConfigError`` prefixed with the section's key.
    """
    data = dict(data or {})
    hints = _hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    for key in data:
        if key not in fields:
            raise _unknown_key(str(key), path, list(fields))
    kwargs = {}
    for name, f in fields.items():
        sub = f"{path}.{name}" if path else name
        if base is not None:
            default = getattr(base, name)
        elif f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = dataclasses.MISSING
        if name in data:
            kwargs[name] = _coerce(data[name], hints.get(name, Any), sub, default)
        elif default is dataclasses.MISSING:
            raise ConfigError(f"missing required config key {sub!r}")
        else:
            kwargs[name] = default
    try:
        return cls(**kwargs)
    except ConfigError as exc:
        raise exc.at(path) from None
    except (ValueError, TypeError) as exc:  # a section's own check, not yet a ConfigError
        where = f"{path}: " if path else ""
        raise ConfigError(f"{where}{exc}", key=path or None) from None


def to_dict(obj) -> Any:
    """A JSON/YAML-ready plain copy of a config (tuples become lists)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_dict(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_dict(v) for v in obj]
    if isinstance(obj, Mapping):
        return {str(k): to_dict(v) for k, v in obj.items()}
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)  # inf thresholds: keep JSON valid
    return obj


def leaf_paths(cls, prefix: str = "", base=None) -> dict[str, tuple[Any, Any]]:
    """``{dotted path: (type, default)}`` of every leaf key of a dataclass tree (cached
    for the plain call ``leaf_paths(cls)``; do not mutate the result)."""
    if not prefix and base is None:
        return _leaf_paths_cached(cls)
    return _leaf_paths(cls, prefix, base)


@functools.lru_cache(maxsize=64)
def _leaf_paths_cached(cls) -> dict[str, tuple[Any, Any]]:
    return _leaf_paths(cls, "", None)


def _leaf_paths(cls, prefix: str = "", base=None) -> dict[str, tuple[Any, Any]]:
    out = {}
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        tp = hints.get(f.name, Any)
        path = f"{prefix}.{f.name}" if prefix else f.name
        if base is not None:
            default = getattr(base, f.name)
        elif f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            try:
                default = f.default_factory()
            except Exception:
                default = dataclasses.MISSING
        else:
            default = dataclasses.MISSING
        if dataclasses.is_dataclass(tp):
            out.update(_leaf_paths(tp, path, _custom_base(tp, default)))
        else:
            out[path] = (tp, default)
    return out


def _section_paths(cls, prefix: str = "") -> list[str]:
    out = []
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        tp = hints.get(f.name, Any)
        if dataclasses.is_dataclass(tp):
            path = f"{prefix}.{f.name}" if prefix else f.name
            out.append(path)
            out.extend(_section_paths(tp, path))
    return out


#: shorthand prefixes that set the same key in several sections at once
ALIASES = {"camera": ("world.cam_a", "world.cam_b")}


def resolve_keys(cls, key: str) -> list[str]:
    """Full dotted paths set by ``key``: an alias (``camera.width`` sets
    ``world.cam_a.width`` and ``world.cam_b.width``) or :func:`resolve_key`."""
    head, _, tail = key.partition(".")
    if head in ALIASES and tail:
        leaves = leaf_paths(cls)
        paths = [f"{p}.{tail}" for p in ALIASES[head]]
        if all(p in leaves for p in paths):
            return paths
        valid = sorted({p[len(ALIASES[head][0]) + 1:] for p in leaves
                        if p.startswith(ALIASES[head][0] + ".")})
        if valid:
            hint = did_you_mean(tail, valid, prefix=head + ".")
            raise ConfigError(f"unknown config key {key!r}{hint}; valid keys of "
                              f"{head}.*: {', '.join(valid)}", key=key)
    return [resolve_key(cls, key)]


def _is_mapping_type(tp) -> bool:
    origin = typing.get_origin(tp) or tp
    return isinstance(origin, type) and issubclass(origin, Mapping)


def resolve_key(cls, key: str) -> str:
    """Full dotted path of ``key``: exact, or the unique path ending in ``.key``. A key
    inside a mapping-valued leaf (``world.path_params.amp_m``) resolves to itself (the
    mapping's owner validates its keys)."""
    leaves = leaf_paths(cls)
    if key in leaves:
        return key
    matches = [p for p in leaves if p.endswith("." + key)]
    if len(matches) == 1:
        return matches[0]
    if not matches:
        inside = set()
        for p, (tp, _) in leaves.items():
            if _is_mapping_type(tp):
                for head in {p, p.rsplit(".", 1)[-1]}:
                    if key.startswith(head + ".") and len(key) > len(head) + 1:
                        inside.add(f"{p}.{key[len(head) + 1:]}")
        if len(inside) == 1:
            return inside.pop()
    if len(matches) > 1:
        raise ConfigError(f"ambiguous config key {key!r}: matches {', '.join(matches)}; "
                          "write the full key", key=key)
    sections = _section_paths(cls)
    if key in sections:
        raise ConfigError(f"{key!r} is a section, not a value; set one of its keys: "
                          f"{', '.join(p for p in leaves if p.startswith(key + '.'))}",
                          key=key)
    hint = did_you_mean(key, list(leaves), cutoff=0.5)
    top = [f.name for f in dataclasses.fields(cls)]
    raise ConfigError(f"unknown config key {key!r}{hint}; valid top-level keys: "
                      f"{', '.join(top)} (python -m simcalib run --help lists every key)",
                      key=key)


def parse_override(item: str) -> tuple[str, str]:
    """``"key=value"`` -> ``("key", "value")`` (the value's text is parsed later, against
    the key's type)."""
    if not isinstance(item, str) or "=" not in item or item.startswith("="):
        raise ConfigError(f"expected key=value, received {item!r}")
    key, raw = item.split("=", 1)
    key = key.strip()
    if not key:
        raise ConfigError(f"override {item!r} has an empty key")
    return key, raw


def parse_overrides(items: Sequence[str]) -> dict[str, str]:
    """``["a=1", "b=[x,y]"]`` -> ``{"a": "1", "b": "[x,y]"}``; a key given twice is an
    error."""
    out: dict[str, str] = {}
    for item in items:
        key, raw = parse_override(item)
        if key in out:
            raise ConfigError(f"key {key!r} given twice ({key}={out[key]} and {item})",
                              key=key)
        out[key] = raw
    return out


def _is_sequence_type(tp) -> bool:
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return any(_is_sequence_type(a) for a in typing.get_args(tp))
    return typing.get_origin(tp) in (tuple, list) or tp in (tuple, list)


def _parse_value(raw: str, tp, path: str = "value"):
    """Parse an override's text for a leaf of type ``tp`` (YAML syntax for numbers,
    booleans, null and lists; strings may be written without quotes). Lists are written
    in brackets, ``[a,b]``: a bare ``a,b`` is rejected with that hint."""
    import yaml
    text = raw.strip()
    if _is_sequence_type(tp) and "," in text and not text.startswith(("[", "(", "'", '"')):
        raise ConfigError(f"{path}: write a list in brackets, {path}=[{text}]; received "
                          f"{text!r}", key=path, value=text)
    non_none = [a for a in typing.get_args(tp) if a is not type(None)] if typing.get_origin(
        tp) in (typing.Union, types.UnionType) else [tp]
    nullable = len(non_none) < len(typing.get_args(tp)) if typing.get_origin(tp) in (
        typing.Union, types.UnionType) else False
    if nullable and text.lower() in ("null", "none", "~", ""):
        return None
    stringy = all(a is str or a is Path or (typing.get_origin(a) is Literal and all(
        isinstance(x, str) for x in typing.get_args(a))) for a in non_none)
    if stringy:
        if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"":
            return text[1:-1]
        return text
    try:
        return yaml.safe_load(text) if text else ""
    except yaml.YAMLError:
        return text


def _set_path(data: dict, path: str, value) -> None:
    parts = path.split(".")
    cur = data
    for p in parts[:-1]:
        nxt = cur.get(p)
        if not isinstance(nxt, dict):
            nxt = {} if nxt is None else dict(nxt) if isinstance(nxt, Mapping) else {}
            cur[p] = nxt
        cur = nxt
    cur[parts[-1]] = value


def apply_overrides(data: Mapping, overrides: Sequence[str] | Mapping[str, Any],
                    cls=None) -> dict:
    """Apply overrides to a nested mapping (a scenario file's content).

    ``overrides`` is a list of ``"key=value"`` strings (the value's text is parsed against
    the key's type: YAML numbers, booleans, ``[a,b]`` lists) or a mapping of dotted key ->
    value (values taken as they are, e.g. from a YAML sweep file). Keys may be unique
    suffixes or aliases (``camera.width``); unknown keys, bad values and a key given twice
    raise :class:`ConfigError`."""
    cls = cls or ScenarioConfig
    out = _deep_copy(data)
    leaves = leaf_paths(cls)
    if isinstance(overrides, Mapping):
        items = [(str(k), v, False) for k, v in overrides.items()]
    else:
        items = [(k, raw, True) for k, raw in parse_overrides(list(overrides)).items()]
    seen: dict[str, str] = {}
    for key, raw, is_text in items:
        for path in resolve_keys(cls, key):
            if path in seen:
                raise ConfigError(f"{path} is set twice (by {seen[path]!r} and {key!r})",
                                  key=path)
            seen[path] = key
            tp = leaves[path][0] if path in leaves else Any   # a key inside a mapping leaf
            value = _parse_value(raw, tp, path) if is_text else raw
            _coerce(value, tp, path)  # type-check now so the message names the override
            _set_path(out, path, value)
    return out


def _deep_copy(data):
    if isinstance(data, Mapping):
        return {k: _deep_copy(v) for k, v in data.items()}
    if isinstance(data, list):
        return [_deep_copy(v) for v in data]
    return data


# ------------------------------------------------------------------------- scenarios
def scenario_dir() -> Path:
    """Directory of the scenario files: ``$SIMCALIB_SCENARIOS``, else the built-in
    ``scenarios/`` (see :mod:`simcalib.resources`)."""
    from simcalib.resources import scenarios_dir
    return scenarios_dir()


def describe_yaml_files(folder: Path) -> dict[str, str]:
    """``{stem: one-line description}`` of the YAML files in ``folder``, sorted (scenarios,
    sweeps); a broken file is listed with its problem."""
    import yaml
    out = {}
    if not folder.is_dir():
        return out
    for p in sorted(folder.glob("*.yaml")):
        try:
            data = yaml.safe_load(p.read_text()) or {}
            desc = str(data.get("description", "")).strip().splitlines()
            out[p.stem] = desc[0] if desc else ""
        except Exception as exc:  # a broken file is listed with its problem
            out[p.stem] = f"(unreadable: {exc})"
    return out


def find_yaml(name: str, folder: Path, kind: str) -> Path:
    """The YAML file of ``kind`` (``"scenario"``, ``"sweep"``) called ``name`` in
    ``folder``, or ``name`` itself when it is a YAML path; unknown names list the valid
    ones with the closest match."""
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{kind} must be a non-empty name; received {name!r}")
    if name.endswith((".yaml", ".yml")) or os.sep in name:
        p = Path(name)
        if not p.is_file():
            raise ConfigError(f"{kind} file {name!r} does not exist")
        return p
    p = folder / f"{name}.yaml"
    if p.is_file():
        return p
    names = list(describe_yaml_files(folder))
    if not names:
        raise ConfigError(f"unknown {kind} {name!r}; no {kind} files found in {folder}"
                          + (" (set SIMCALIB_SCENARIOS)" if kind == "scenario" else ""),
                          key=kind, value=name)
    raise unknown_choice(kind, name, names)


def list_scenarios() -> dict[str, str]:
    """``{name: one-line description}`` of the scenario files, sorted by name."""
    return describe_yaml_files(scenario_dir())


def scenario_path(name: str) -> Path:
    """Path of scenario ``name`` (a name in the scenario directory or a YAML file path)."""
    return find_yaml(name, scenario_dir(), "scenario")


def load_scenario_data(scenario: str | Mapping) -> dict:
    """The raw mapping of a scenario (name, YAML path or mapping), with ``scenario`` set.

    A YAML syntax error names the file, line and column."""
    import yaml
    if isinstance(scenario, Mapping):
        data = dict(scenario)
        data.setdefault("scenario", "custom")
        return data
    path = scenario_path(scenario)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"scenario file {str(path)!r} is not valid YAML: "
                          f"{_yaml_error_text(exc)}", key="scenario", value=str(path)) from None
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"scenario file {str(path)!r} must hold a mapping of keys; "
                          f"it holds a {type(data).__name__}", key="scenario",
                          value=str(path))
    data = dict(data)
    data.setdefault("scenario", path.stem)
    return data


def _yaml_error_text(exc) -> str:
    """``"line 3, column 7: mapping values are not allowed here"`` from a YAML error."""
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).strip().splitlines()[0]
    if mark is not None:
        return f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return str(problem)


def load_config(scenario: str | Mapping | ScenarioConfig,
                overrides: Sequence[str] | Mapping[str, Any] = ()) -> ScenarioConfig:
    """Resolve a scenario (name, YAML path, mapping or a config) plus overrides (``"k=v"``
    strings or a mapping of dotted key -> value) into a validated :class:`ScenarioConfig`.

    Everything is checked here, before any work: unknown keys (closest match named),
    types, ranges, solver names, and whether the path fits the pairing thresholds."""
    if isinstance(scenario, ScenarioConfig):
        scenario = to_dict(scenario)
    data = load_scenario_data(scenario)
    return build(ScenarioConfig, apply_overrides(data, overrides))


def load_configs(scenario: str | Mapping | ScenarioConfig,
                 override_sets: Sequence[Sequence[str] | Mapping[str, Any]], *,
                 max_errors: int = 5) -> list[ScenarioConfig]:
    """One validated config per override set over one base scenario (a sweep's cells).

    The base file is read once. Every set is validated before returning; if any fails,
    one :class:`ConfigError` lists the failing sets (index, overrides and the reason; at
    most ``max_errors``, then a count), so a sweep is rejected before any work."""
    if isinstance(scenario, ScenarioConfig):
        scenario = to_dict(scenario)
    data = load_scenario_data(scenario)
    configs, errors = [], []
    for i, overrides in enumerate(override_sets):
        try:
            configs.append(build(ScenarioConfig, apply_overrides(data, overrides)))
        except ConfigError as exc:
            errors.append((i, overrides, exc))
    if errors:
        lines = [f"cell {i} ({_show_overrides(o)}): {e}" for i, o, e in errors[:max_errors]]
        more = len(errors) - max_errors
        tail = f"; and {more} more" if more > 0 else ""
        raise ConfigError(f"{len(errors)} of {len(override_sets)} override sets are invalid: "
                          + "; ".join(lines) + tail)
    return configs


def _show_overrides(overrides) -> str:
    if isinstance(overrides, Mapping):
        return " ".join(f"{k}={v}" for k, v in overrides.items())
    return " ".join(overrides)


def describe_keys(cls=None) -> list[str]:
    """One line per leaf key: ``path  type  = default   help`` (for ``run --help``)."""
    cls = cls or ScenarioConfig
    lines = []
    helps = _field_helps(cls)
    for path, (tp, default) in leaf_paths(cls).items():
        d = "(required)" if default is dataclasses.MISSING else repr(to_dict(default))
        h = helps.get(path, "")
        lines.append(f"  {path:<34} {_type_name(tp):<26} = {d}" + (f"   {h}" if h else ""))
    return lines


def _field_helps(cls, prefix: str = "") -> dict[str, str]:
    out = {}
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        path = f"{prefix}.{f.name}" if prefix else f.name
        tp = hints.get(f.name, Any)
        if dataclasses.is_dataclass(tp):
            out.update(_field_helps(tp, path))
        elif f.metadata.get("help") or f.metadata.get("doc"):
            out[path] = f.metadata.get("help") or f.metadata.get("doc")
    return out
