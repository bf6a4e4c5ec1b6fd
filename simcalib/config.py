"""Typed scenario configuration: frozen dataclasses loaded from YAML, dotted overrides.

A scenario file (``scenarios/NAME.yaml``) is a partial :class:`ScenarioConfig`; every key
it leaves out takes the dataclass default. Command-line overrides are dotted keys with
typed values::

    seed=3 output=runs/x noise.sigma_r_deg=1.0 solvers=[dqopt,daniilidis] source=noisy
    alpha=0.5 camera.width=1280

A key may be abbreviated to any unique suffix of its full dotted path (``camera.width`` for
``world.camera.width``). An unknown key, an ambiguous abbreviation or a value of the wrong
type raises ``ValueError`` naming the key, what was received, and the valid keys / values
(with the closest match) — before any work starts.

The generic machinery (:func:`build`, :func:`to_dict`, :func:`leaf_paths`,
:func:`apply_overrides`) works on any frozen dataclass tree, so the stage configs owned by
other modules (``WorldConfig``, ``VisionConfig``, ``SyntheticConfig``) are composed, not
copied.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

__all__ = [
    "ConfigError",
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
    "scenario_dir",
    "scenario_path",
    "to_dict",
]


class ConfigError(ValueError):
    """A configuration problem (unknown key, bad value, unknown scenario)."""


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
        for name in ("sigma_r_deg", "sigma_t_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"noise.{name} must be finite and >= 0; received {v}")


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
        if self.step < 1:
            raise ConfigError(f"pairing.step must be >= 1; received {self.step}")
        if self.n_pairs < 2:
            raise ConfigError(f"pairing.n_pairs must be >= 2; received {self.n_pairs}")
        for name in ("max_time_diff_s", "max_translation_m", "max_rotation_deg"):
            v = getattr(self, name)
            if not (v > 0):
                raise ConfigError(f"pairing.{name} must be > 0 (use inf to disable); "
                                  f"received {v}")


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
        for name in ("a", "b"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"prior.{name} must be finite and > 0; received {v}")
        for name in ("rotation_error_deg", "translation_error_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"prior.{name} must be finite and >= 0; received {v}")
        if (self.translation_m is None) != (self.rotvec_deg is None):
            raise ConfigError("prior.translation_m and prior.rotvec_deg must be given "
                              "together (or neither, for a perturbed true X)")


@dataclass(frozen=True)
class RecordingConfig:
    """The rerun recording (``recording.rrd`` in the run directory)."""
    enabled: bool = field(default=True, metadata=_doc("write recording.rrd"))
    jpeg_quality: int = field(default=70, metadata=_doc("JPEG quality of logged images"))
    max_images: int = field(default=150, metadata=_doc(
        "at most this many images per camera are logged (evenly subsampled)"))

    def __post_init__(self):
        if not (1 <= self.jpeg_quality <= 100):
            raise ConfigError(f"recording.jpeg_quality must be in [1, 100]; "
                              f"received {self.jpeg_quality}")
        if self.max_images < 0:
            raise ConfigError(f"recording.max_images must be >= 0; received {self.max_images}")


SOURCES = ("ground_truth", "noisy", "aruco", "robot_fk")
KINDS = ("sim", "synthetic")


@dataclass(frozen=True)
class ScenarioConfig:
    """One end-to-end run: world -> pose streams -> motion pairs -> solvers -> evaluation."""
    scenario: str = field(default="custom", metadata=_doc("scenario name"))
    description: str = field(default="", metadata=_doc("one-line description"))
    kind: Literal["sim", "synthetic"] = field(default="sim", metadata=_doc(
        "sim: MuJoCo world (world.*, vision.*); synthetic: paper appendix D.2 (synthetic.*)"))
    source: Literal["ground_truth", "noisy", "aruco", "robot_fk"] = field(
        default="aruco", metadata=_doc("pose source of both streams (unless streams.a/b.source "
                                       "says otherwise)"))
    seed: int = field(default=0, metadata=_doc("seed of every random draw of the run"))
    output: str | None = field(default=None, metadata=_doc(
        "run directory (default runs/<scenario>-<timestamp>)"))
    solvers: tuple[str, ...] = field(default=("dqopt", "dq2ndord", "dqconvrlx", "dq2steps",
                                              "daniilidis"), metadata=_doc(
        "methods to run (python -m simcalib list)"))
    alpha: float | tuple[float, ...] = field(default=1.0, metadata=_doc(
        "translation weight alpha, or a list (a sweep: each method reports every alpha "
        "and, as its headline, the alpha with the lowest rotation error)"))
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

    def __post_init__(self):
        if self.seed < 0:
            raise ConfigError(f"seed must be >= 0; received {self.seed}")
        if self.workers < 1:
            raise ConfigError(f"workers must be >= 1; received {self.workers}")
        if self.kind == "synthetic" and self.source in ("aruco", "robot_fk"):
            raise ConfigError(f"source={self.source} needs a simulated world (kind=sim); a "
                              "synthetic scenario allows source=ground_truth or source=noisy")
        for key in ("a", "b"):
            name = getattr(self.streams, key).source
            if name is not None and name not in SOURCES:
                close = difflib.get_close_matches(name, SOURCES, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ConfigError(f"streams.{key}.source: unknown source {name!r}{hint}; "
                                  f"valid: {', '.join(SOURCES)} (or null: the run's source)")
            if name is not None and self.kind == "synthetic":
                raise ConfigError(f"streams.{key}.source applies to simulated worlds "
                                  "(kind=sim); a synthetic scenario measures with its own "
                                  "source")
        if not self.solvers:
            raise ConfigError("solvers must name at least one method")
        if len(set(self.solvers)) != len(self.solvers):
            raise ConfigError(f"solvers lists a method twice: {list(self.solvers)}")
        for a in self.alphas:
            if not (math.isfinite(a) and a > 0):
                raise ConfigError(f"alpha must be finite and > 0; received {a}")
        _check_solver_names(self.solvers, "solvers")
        if self.prior.enabled:
            _check_solver_names(self.prior.methods, "prior.methods")
            from simcalib.solvers import registry
            no_prior = [m for m in self.prior.methods if not registry.get(m).supports_prior]
            if no_prior:
                ok = [i.name for i in registry.infos() if i.supports_prior]
                raise ConfigError(f"prior.methods: {', '.join(no_prior)} cannot use a prior; "
                                  f"methods with a prior: {', '.join(ok)}")
        if self.kind == "synthetic" and not getattr(type(self.synthetic), "_simcalib_missing",
                                                    None):
            self._sync_synthetic_noise()
        missing = getattr(type(self.world if self.kind == "sim" else self.synthetic),
                          "_simcalib_missing", None)
        if missing:
            raise ConfigError(f"kind={self.kind} needs {missing}, which is not available "
                              "in this installation")
        if self.kind == "sim" and self.source == "aruco" and getattr(
                type(self.vision), "_simcalib_missing", None):
            raise ConfigError("source=aruco needs simcalib.vision, which is not available "
                              "in this installation")

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
                                  f"noise.sigma_r_deg / noise.sigma_t_m instead")
        object.__setattr__(self, "synthetic", dataclasses.replace(
            syn, sigma_r_rad=want_r, sigma_t_m=want_t))

    @property
    def alphas(self) -> tuple[float, ...]:
        return tuple(self.alpha) if isinstance(self.alpha, tuple) else (float(self.alpha),)

    @property
    def is_sweep(self) -> bool:
        return isinstance(self.alpha, tuple) and len(self.alpha) > 1


def _check_solver_names(names: Sequence[str], key: str) -> None:
    from simcalib.solvers import registry
    valid = registry.available()
    for name in names:
        if name not in valid:
            close = difflib.get_close_matches(name, valid, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ConfigError(f"{key}: unknown method {name!r}{hint}; available: "
                              f"{', '.join(valid) if valid else '(none registered)'}")


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
    return ConfigError(f"{path}: expected {expected}; received {value!r}{extra}")


def _coerce(value, tp, path: str, default=dataclasses.MISSING):
    """Convert a YAML/override value to the annotated type ``tp`` or raise ConfigError."""
    if tp is Any or tp is object:
        return value
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if dataclasses.is_dataclass(tp):
        if dataclasses.is_dataclass(value) and isinstance(value, tp):
            return value
        if not isinstance(value, Mapping):
            raise _fail(path, value, f"a mapping of the keys of section {path!r}")
        return build(tp, value, path=path, base=_custom_base(tp, default))
    if origin is Literal:
        if value in args:
            return value
        opts = [str(a) for a in args]
        close = difflib.get_close_matches(str(value), opts, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ConfigError(f"{path}: invalid value {value!r}{hint}; allowed: "
                          f"{', '.join(opts)}")
    if origin in (typing.Union, types.UnionType):
        if value is None:
            if type(None) in args:
                return None
            raise _fail(path, value, _type_name(tp))
        non_none = [a for a in args if a is not type(None)]
        seq = [a for a in non_none if typing.get_origin(a) in (tuple, list)]
        scalar = [a for a in non_none if a not in seq]
        order = (seq + scalar) if isinstance(value, (list, tuple)) else (scalar + seq)
        errors = []
        for a in order:
            try:
                return _coerce(value, a, path)
            except ConfigError as exc:
                errors.append(str(exc))
        if len(errors) == 1:
            raise ConfigError(errors[0])
        raise _fail(path, value, _type_name(tp))
    if origin in (tuple, list):
        if isinstance(value, str) or not isinstance(value, (list, tuple)):
            value = [value]  # a scalar for a list field: a one-element list
        if len(args) == 2 and args[1] is Ellipsis:
            out = [_coerce(v, args[0], f"{path}[{i}]") for i, v in enumerate(value)]
        elif args:
            if len(value) != len(args):
                raise _fail(path, value, f"a list of {len(args)} values "
                                         f"({_type_name(tp)})")
            out = [_coerce(v, a, f"{path}[{i}]") for i, (v, a) in enumerate(zip(value, args))]
        else:
            out = list(value)
        return tuple(out) if origin is tuple else out
    if tp in (tuple, list):  # unparametrised sequence: a scalar is a one-element list
        seq = [value] if isinstance(value, str) or not isinstance(value, (list, tuple)) \
            else list(value)
        return tuple(seq) if tp is tuple else seq
    if origin is dict or tp is dict:
        if not isinstance(value, Mapping):
            raise _fail(path, value, "a mapping")
        return dict(value)
    if tp is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false", "yes", "no", "on", "off"):
            return value.lower() in ("true", "yes", "on")
        raise _fail(path, value, "a boolean (true or false)")
    if tp is int:
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
    if tp is float:
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
    if tp is str:
        if isinstance(value, str):
            return value
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return str(value)
        raise _fail(path, value, "a string")
    if tp is Path:
        if isinstance(value, (str, Path)):
            return Path(value)
        raise _fail(path, value, "a path")
    if isinstance(tp, type):
        if isinstance(value, tp):
            return value
        try:
            return tp(value)
        except Exception:
            raise _fail(path, value, _type_name(tp)) from None
    return value


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
    close = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.5)
    hint = f" (did you mean {(path + '.' if path else '') + close[0]!r}?)" if close else ""
    where = f"section {path!r}" if path else "the top level"
    return ConfigError(f"unknown config key {full!r}{hint}; valid keys in {where}: "
                       f"{', '.join(valid) if valid else '(none)'}")


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
    except ConfigError:
        raise
    except (ValueError, TypeError) as exc:
        where = f"{path}: " if path else ""
        raise ConfigError(f"{where}{exc}") from None


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
    """``{dotted path: (type, default)}`` of every leaf key of a dataclass tree."""
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
            out.update(leaf_paths(tp, path, _custom_base(tp, default)))
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
            close = difflib.get_close_matches(tail, valid, n=1)
            hint = f" (did you mean '{head}.{close[0]}'?)" if close else ""
            raise ConfigError(f"unknown config key {key!r}{hint}; valid keys of "
                              f"{head}.*: {', '.join(valid)}")
    return [resolve_key(cls, key)]


def resolve_key(cls, key: str) -> str:
    """Full dotted path of ``key``: exact, or the unique path ending in ``.key``."""
    leaves = leaf_paths(cls)
    if key in leaves:
        return key
    matches = [p for p in leaves if p.endswith("." + key)]
    if len(matches) == 1:
        return matches[0]
    if len(matches) > 1:
        raise ConfigError(f"ambiguous config key {key!r}: matches {', '.join(matches)}; "
                          "write the full key")
    sections = _section_paths(cls)
    if key in sections:
        raise ConfigError(f"{key!r} is a section, not a value; set one of its keys: "
                          f"{', '.join(p for p in leaves if p.startswith(key + '.'))}")
    names = list(leaves)
    close = difflib.get_close_matches(key, names, n=1, cutoff=0.5)
    if not close:  # try the last components against the tails of every path
        tails = {p.split(".", p.count(".") - key.count("."))[-1] if p.count(".") >= key.count(".")
                 else p: p for p in names}
        c2 = difflib.get_close_matches(key, list(tails), n=1, cutoff=0.5)
        close = [tails[c2[0]]] if c2 else []
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    top = [f.name for f in dataclasses.fields(cls)]
    raise ConfigError(f"unknown config key {key!r}{hint}; valid top-level keys: "
                      f"{', '.join(top)} (python -m simcalib run --help lists every key)")


def parse_override(item: str) -> tuple[str, str]:
    if not isinstance(item, str) or "=" not in item:
        raise ConfigError(f"overrides are key=value; received {item!r}")
    key, raw = item.split("=", 1)
    key = key.strip()
    if not key:
        raise ConfigError(f"override {item!r} has an empty key")
    return key, raw


def _parse_value(raw: str, tp):
    """Parse an override's text for a leaf of type ``tp`` (YAML syntax for numbers,
    booleans, null and lists; strings may be written without quotes)."""
    import yaml
    text = raw.strip()
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


def apply_overrides(data: Mapping, overrides: Sequence[str], cls=None) -> dict:
    """Apply ``key=value`` overrides to a nested mapping (a scenario file's content)."""
    cls = cls or ScenarioConfig
    out = _deep_copy(data)
    leaves = leaf_paths(cls)
    for item in overrides:
        key, raw = parse_override(item)
        for path in resolve_keys(cls, key):
            tp = leaves[path][0]
            value = _parse_value(raw, tp)
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
    """Directory of the scenario files: ``$SIMCALIB_SCENARIOS``, else ``scenarios/`` of the
    source tree (editable install / checkout), else ``./scenarios``."""
    env = os.environ.get("SIMCALIB_SCENARIOS")
    if env:
        return Path(env)
    repo = Path(__file__).resolve().parent.parent / "scenarios"
    if repo.is_dir():
        return repo
    return Path.cwd() / "scenarios"


def list_scenarios() -> dict[str, str]:
    """``{name: one-line description}`` of the scenario files, sorted by name."""
    import yaml
    out = {}
    d = scenario_dir()
    if not d.is_dir():
        return out
    for p in sorted(d.glob("*.yaml")):
        try:
            data = yaml.safe_load(p.read_text()) or {}
            desc = str(data.get("description", "")).strip().splitlines()
            out[p.stem] = desc[0] if desc else ""
        except Exception as exc:  # a broken file is listed with its problem
            out[p.stem] = f"(unreadable: {exc})"
    return out


def scenario_path(name: str) -> Path:
    """Path of scenario ``name`` (a name in the scenario directory or a YAML file path)."""
    if not isinstance(name, str) or not name:
        raise ConfigError(f"scenario must be a non-empty name; received {name!r}")
    if name.endswith((".yaml", ".yml")) or os.sep in name:
        p = Path(name)
        if not p.is_file():
            raise ConfigError(f"scenario file {name!r} does not exist")
        return p
    p = scenario_dir() / f"{name}.yaml"
    if p.is_file():
        return p
    names = list(list_scenarios())
    close = difflib.get_close_matches(name, names, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise ConfigError(f"unknown scenario {name!r}{hint}; available: "
                      f"{', '.join(names) if names else '(none found in ' + str(scenario_dir()) + ')'}")


def load_config(scenario: str | Mapping, overrides: Sequence[str] = ()) -> ScenarioConfig:
    """Resolve a scenario (name, YAML path or mapping) plus overrides into a config.

    Everything is validated here: unknown keys, types, ranges, solver names.
    """
    import yaml
    if isinstance(scenario, Mapping):
        data = dict(scenario)
        name = str(data.get("scenario", "custom"))
    else:
        path = scenario_path(scenario)
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError as exc:
            raise ConfigError(f"scenario file {str(path)!r} is not valid YAML: "
                              f"{str(exc).splitlines()[0]}") from None
        if not isinstance(data, Mapping):
            raise ConfigError(f"scenario file {str(path)!r} must hold a mapping of keys; "
                              f"it holds a {type(data).__name__}")
        name = path.stem
        data = dict(data)
        data.setdefault("scenario", name)
    data = apply_overrides(data, list(overrides))
    return build(ScenarioConfig, data)


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
