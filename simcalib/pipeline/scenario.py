"""The scenario schema: :class:`ScenarioConfig`, assembled from the sections their owners
define (``world`` — :mod:`simcalib.world.config`, ``robot`` — :mod:`simcalib.world.robot_error`,
``outliers`` — :mod:`simcalib.sources.corruption`, ``streams`` — :mod:`simcalib.sources.selection`,
``estimation`` — :mod:`simcalib.estimation.config`, ``vision``, ``synthetic``) plus the run's
own (noise, pairing, prior, recording, verdict), and the scenario files
(``scenarios/NAME.yaml``, each a partial :class:`ScenarioConfig`).

The generic machinery is :mod:`simcalib.config.engine`; the wrappers here
(:func:`apply_overrides`, :func:`resolve_keys`, :func:`describe_keys`) pass it the
scenario's root and :data:`ALIASES` (``camera.*`` sets both cameras)::

    seed=3 output=runs/x noise.sigma_r_deg=1.0 solvers=[dqopt,daniilidis] camera.width=1280

Everything is checked in :func:`load_config`, before any work (feasibility of the path:
:mod:`simcalib.pipeline.feasibility`).
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

from simcalib.config import engine
from simcalib.config.checks import (check_in, check_int, check_names, check_positive,
                                    check_range, check_that, check_vector, set_fields)
from simcalib.config.engine import build, key_help, to_dict
from simcalib.config.files import _yaml_error_text, describe_yaml_files, find_yaml
from simcalib.errors import ConfigError, unknown_choice

__all__ = ["ALIASES", "NoiseConfig", "PairingConfig", "PriorConfig", "RecordingConfig",
           "ScenarioConfig", "VerdictConfig", "apply_overrides", "describe_keys",
           "list_scenarios", "load_config", "load_configs", "load_scenario_data",
           "resolve_keys", "scenario_dir", "scenario_path"]


# ----------------------------------------------------------------- composed sections
from simcalib.estimation.config import EstimationConfig  # noqa: E402
from simcalib.sources.corruption import OutliersConfig  # noqa: E402
from simcalib.sources.selection import StreamsConfig  # noqa: E402
from simcalib.sources.vision.config import VisionConfig  # noqa: E402
from simcalib.world.config import WorldConfig  # noqa: E402
from simcalib.world.robot_error import RobotConfig  # noqa: E402
from simcalib.world.synthetic import SyntheticConfig  # noqa: E402



@dataclass(frozen=True)
class NoiseConfig:
    """Pose noise of the ``noisy`` source (paper eq. 38), applied to each camera's poses."""
    sigma_r_deg: float = field(default=0.57, metadata=key_help(
        "rotation noise: angle ~ N(0, sigma_r^2) about a uniform axis, degrees"))
    sigma_t_m: float = field(default=0.01, metadata=key_help(
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
    mode: Literal["consecutive", "random"] = field(default="consecutive", metadata=key_help(
        "consecutive: every surviving pair; random: draw n_pairs of them"))
    step: int = field(default=1, metadata=key_help(
        "pair matched datapoint k with k + step"))
    n_pairs: int = field(default=100, metadata=key_help(
        "random mode: number of pairs drawn (without replacement when enough exist)"))
    prefilter: bool = field(default=True, metadata=key_help(
        "apply the appendix D.1 pre-filter (the three thresholds below)"))
    max_time_diff_s: float = field(default=0.1, metadata=key_help(
        "drop datapoints whose two camera timestamps differ by more than this, seconds"))
    max_translation_m: float = field(default=0.10, metadata=key_help(
        "drop pairs where a camera moved more than this, metres"))
    max_rotation_deg: float = field(default=11.5, metadata=key_help(
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
    enabled: bool = field(default=False, metadata=key_help("run the methods below with the prior"))
    methods: tuple[str, ...] = field(default=("dqopt",), metadata=key_help(
        "methods run a second time with the prior"))
    a: float = field(default=1e-4, metadata=key_help(
        "weight of the rotation prior (relative to the data cost: small, so determined "
        "directions keep the data value)"))
    b: float = field(default=1e-2, metadata=key_help(
        "weight of the translation prior (the undetermined translation takes its value)"))
    rotation_error_deg: float = field(default=2.0, metadata=key_help(
        "error of the simulated nominal extrinsic's rotation, degrees"))
    translation_error_m: float = field(default=0.02, metadata=key_help(
        "error of the simulated nominal extrinsic's translation, metres"))
    translation_m: tuple[float, float, float] | None = field(default=None, metadata=key_help(
        "explicit nominal translation of X (metres); with rotvec_deg"))
    rotvec_deg: tuple[float, float, float] | None = field(default=None, metadata=key_help(
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
    enabled: bool = field(default=True, metadata=key_help("write recording.rrd"))
    jpeg_quality: int = field(default=70, metadata=key_help("JPEG quality of logged images"))
    max_images: int = field(default=150, metadata=key_help(
        "at most this many images per camera are logged (evenly subsampled)"))
    background: bool = field(default=True, metadata=key_help(
        "write it from a worker process, so rerun's import and the logging overlap the run "
        "(a process that has imported rerun already logs in-process)"))

    def __post_init__(self):
        set_fields(self, jpeg_quality=check_int("jpeg_quality", self.jpeg_quality, lo=1, hi=100),
                   max_images=check_int("max_images", self.max_images, lo=0))


@dataclass(frozen=True)
class VerdictConfig:
    """When an estimate is trusted: a direction of X whose predicted 1-sigma
    exceeds a tolerance is "poorly determined" (``Solution.verdict``), and the curve of
    error and predicted sigma against the number of motions used (``convergence``)."""
    tolerance_deg: float = field(default=1.0, metadata=key_help(
        "1-sigma rotation tolerance, degrees (above it: poorly determined)"))
    tolerance_m: float = field(default=0.01, metadata=key_help(
        "1-sigma translation tolerance, metres (above it: poorly determined)"))
    convergence_points: int = field(default=10, metadata=key_help(
        "solve on the first k motions for this many log-spaced k (0: no curve)"))

    def __post_init__(self):
        set_fields(self,
                   tolerance_deg=check_positive("tolerance_deg", self.tolerance_deg),
                   tolerance_m=check_positive("tolerance_m", self.tolerance_m),
                   convergence_points=check_int("convergence_points",
                                                self.convergence_points, lo=0, hi=100))


from simcalib.sources import KINDS, available_sources, sources_for_kind  # noqa: E402

#: the pose sources of a simulated world: whatever registered itself (simcalib.sources)
SOURCES = sources_for_kind("sim")


@dataclass(frozen=True)
class _ScenarioSections:
    """The scenario's own sections and the shared ones; :data:`ScenarioConfig` adds the
    sections the registered pose sources own (``SourceInfo.config``)."""
    scenario: str = field(default="custom", metadata=key_help("scenario name"))
    description: str = field(default="", metadata=key_help("one-line description"))
    kind: Literal[KINDS] = field(default="sim", metadata=key_help(
        "sim: MuJoCo world (world.*, vision.*); synthetic: paper appendix D.2 (synthetic.*)"))
    source: str = field(
        default="aruco", metadata=key_help(
            "pose source of both streams (unless streams.a/b.source says otherwise): a "
            "registered source (simcalib.sources)"))
    seed: int = field(default=0, metadata=key_help("seed of every random draw of the run"))
    output: str | None = field(default=None, metadata=key_help(
        "run directory (default runs/<scenario>-<timestamp>)"))
    overwrite: bool = field(default=False, metadata=key_help(
        "replace an earlier run's results in output (else an output holding results.json "
        "or extrinsics.json is refused before any work)"))
    solvers: tuple[str, ...] = field(default=("dqopt", "dq2ndord", "dqconvrlx", "dq2steps",
                                              "daniilidis"), metadata=key_help(
        "methods to run (python -m simcalib list)"))
    alpha: Literal["auto"] | float | tuple[float, ...] = field(default="auto", metadata=key_help(
        "translation weight alpha (1/m): auto (chosen from the data: "
        "simcalib.solvers.diagnostics.uncertainty.choose_alpha), a number, or a list (a "
        "sweep: every alpha is reported; the headline stays the data-chosen alpha and the "
        "list's alpha best against the ground truth is reported beside it as oracle_alpha)"))
    workers: int = field(default=2, metadata=key_help("parallel render workers"))
    progress: bool = field(default=True, metadata=key_help("show progress bars"))
    world: WorldConfig = field(default_factory=WorldConfig, metadata=key_help("simulated world"))
    vision: VisionConfig = field(default_factory=VisionConfig, metadata=key_help(
        "visual (ArUco) pose source"))
    synthetic: SyntheticConfig = field(default_factory=SyntheticConfig, metadata=key_help(
        "synthetic generator"))
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    pairing: PairingConfig = field(default_factory=PairingConfig)
    prior: PriorConfig = field(default_factory=PriorConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    streams: StreamsConfig = field(default_factory=StreamsConfig, metadata=key_help(
        "per-stream pose sources (a = cam_a, b = cam_b)"))
    robot: RobotConfig = field(default_factory=RobotConfig, metadata=key_help(
        "arm kinematic error and encoders (robot_fk)"))
    outliers: OutliersConfig = field(default_factory=OutliersConfig, metadata=key_help(
        "injected outliers with ground-truth labels"))
    verdict: VerdictConfig = field(default_factory=VerdictConfig, metadata=key_help(
        "tolerances of the degeneracy verdict and the convergence curve"))
    estimation: EstimationConfig = field(default_factory=EstimationConfig, metadata=key_help(
        "streams -> motions: the paper's pairing, or calibrate's recorded-data path"))

    def __post_init__(self):
        set_fields(self, seed=check_int("seed", self.seed, lo=0),
                   workers=check_int("workers", self.workers, lo=1))
        self._check_source()
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
        if self.kind == "synthetic":
            self._sync_synthetic_noise()
        if self.kind == "sim":
            from simcalib.pipeline.feasibility import check_outdoor_source, check_path_feasible
            from simcalib.sources import camera_sources, get_source
            check_outdoor_source(self)
            for name in dict.fromkeys(camera_sources(self, "sim").values()):
                get_source(name, "sim").check_config(self)
            check_path_feasible(self)

    def _check_source(self):
        """``source`` names a registered source that can measure this ``kind`` (a
        synthetic scenario stands in for a source whose ``SourceInfo.synthetic_stand_in``)."""
        infos = available_sources()
        if self.source not in infos or (self.kind == "sim" and "sim" not in
                                        infos[self.source].kinds):
            raise unknown_choice("pose source", self.source, list(SOURCES), key="source")
        if self.kind == "synthetic" and not infos[self.source].synthetic_stand_in:
            ok = " or ".join(f"source={n}" for n, i in infos.items() if i.synthetic_stand_in)
            raise ConfigError(f"source={self.source} needs a simulated world (kind=sim); a "
                              f"synthetic scenario allows {ok}", key="source",
                              value=self.source)

    def _sync_synthetic_noise(self):
        """``noise.*`` is the one place measurement noise is set: the synthetic generator's
        ``sigma_r_rad``/``sigma_t_m`` follow it (zero for ``source=ground_truth``); setting
        them to something else is a conflict."""
        syn = self.synthetic
        base = type(syn)()
        if available_sources()[self.source].exact:
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


def _assemble(base: type) -> type:
    """``ScenarioConfig``: ``base`` plus one section ``<name>`` per registered pose source
    that owns one (``SourceInfo.config``), in name order, after the built-in sections."""
    taken = {f.name for f in dataclasses.fields(base)}
    sections = []
    for name, info in available_sources().items():
        if info.config is None:
            continue
        if name in taken:
            raise TypeError(f"pose source {name!r} owns a config section, but {name!r} is "
                            "already a key of the scenario; rename the source")
        sections.append((name, info.config, field(
            default_factory=info.config,
            metadata=key_help(f"pose source {name}: {info.description}"))))
    cls = dataclasses.make_dataclass("ScenarioConfig", sections, bases=(base,), frozen=True)
    cls.__module__ = __name__
    hints = typing.get_type_hints(cls)
    cls.__doc__ = ("One end-to-end run: world -> pose streams -> motion pairs -> solvers "
                   "-> evaluation. Sections: " + ", ".join(
                       n for n, tp in hints.items() if dataclasses.is_dataclass(tp)) + ".")
    return cls


#: One end-to-end run (the scenario schema): the sections above plus each pose source's
#: own (``SourceInfo.config``: a new source with settings adds its section here without
#: editing this file).
ScenarioConfig = _assemble(_ScenarioSections)


def _check_solver_names(names: Sequence[str], key: str) -> None:
    from simcalib.solvers import registry
    valid = registry.available()
    for name in names:
        if name not in valid:
            raise unknown_choice("method", name, valid, key=key)


# ------------------------------------------------------------------------- scenarios
def scenario_dir() -> Path:
    """Directory of the scenario files: ``$SIMCALIB_SCENARIOS``, else the built-in
    ``scenarios/`` (see :mod:`simcalib.config.resources`)."""
    from simcalib.config.resources import scenarios_dir
    return scenarios_dir()


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


#: shorthand prefixes that set the same key in several sections at once
ALIASES = {"camera": ("world.cam_a", "world.cam_b")}


def resolve_keys(cls, key: str) -> list[str]:
    """Full dotted paths set by ``key`` in ``cls`` with the scenario's :data:`ALIASES`
    (:func:`simcalib.config.engine.resolve_keys`)."""
    return engine.resolve_keys(cls, key, ALIASES)


def apply_overrides(data: Mapping, overrides: Sequence[str] | Mapping[str, Any],
                    cls=None) -> dict:
    """:func:`simcalib.config.engine.apply_overrides` on ``cls`` (default
    :class:`ScenarioConfig`) with the scenario's :data:`ALIASES`."""
    return engine.apply_overrides(data, overrides, cls or ScenarioConfig, ALIASES)


def describe_keys(cls=None) -> list[str]:
    """One line per leaf key of ``cls`` (default :class:`ScenarioConfig`), for ``--help``."""
    return engine.describe_keys(cls or ScenarioConfig)
