"""The config engine: frozen dataclass trees built from nested mappings (YAML), dotted
``key=value`` overrides, :func:`to_dict`. It knows no schema: the caller passes the root
dataclass and its aliases (:mod:`simcalib.pipeline.scenario` assembles the scenario's).

Overrides are dotted keys with YAML-typed values (``seed=3``, ``noise.sigma_r_deg=1.0``,
``solvers=[a,b]``); a key may be abbreviated to any unique suffix of its full dotted path;
an alias prefix sets the same key in several sections (``aliases={"camera": ("world.cam_a",
"world.cam_b")}``). An unknown key, an ambiguous abbreviation or a bad value raises
:class:`~simcalib.errors.ConfigError` naming the key, what was received and what is allowed
(with the closest match). Lists have one syntax everywhere: ``[a,b]``; a single value for a
list key is a one-element list.

Why one hand-written coercer rather than pydantic v2: the schemas are plain frozen
dataclasses that library code builds directly from Python (stage configs, experiment
configs, results), so a small coercer over ``typing`` hints (:func:`_coerce`, one helper
per kind of type) keeps them import-light and gives exactly the messages, suffix keys and
aliases the CLI needs. Range checks live in each dataclass's ``__post_init__``, written
with the helpers of :mod:`simcalib.config.checks`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

from simcalib.errors import ConfigError, did_you_mean

__all__ = ["apply_overrides", "build", "describe_keys", "key_help", "leaf_paths",
           "parse_override", "parse_overrides", "resolve_key", "resolve_keys", "to_dict"]


def key_help(text: str) -> dict:
    """``field(..., metadata=key_help("..."))``: a config key's help text, which
    :func:`describe_keys` (``--help``) prints beside the key."""
    return {"help": text}


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


def resolve_keys(cls, key: str, aliases: Mapping[str, Sequence[str]] | None = None
                 ) -> list[str]:
    """Full dotted paths set by ``key``: an alias (``aliases`` maps a shorthand prefix to
    the sections it sets at once, e.g. ``{"camera": ("world.cam_a", "world.cam_b")}``:
    ``camera.width`` sets both widths) or :func:`resolve_key`."""
    ALIASES = aliases or {}
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
                    cls, aliases: Mapping[str, Sequence[str]] | None = None) -> dict:
    """Apply overrides to a nested mapping (a scenario file's content).

    ``overrides`` is a list of ``"key=value"`` strings (the value's text is parsed against
    the key's type: YAML numbers, booleans, ``[a,b]`` lists) or a mapping of dotted key ->
    value (values taken as they are, e.g. from a YAML sweep file). Keys may be unique
    suffixes or aliases (``camera.width``); unknown keys, bad values and a key given twice
    raise :class:`ConfigError`."""
    out = _deep_copy(data)
    leaves = leaf_paths(cls)
    if isinstance(overrides, Mapping):
        items = [(str(k), v, False) for k, v in overrides.items()]
    else:
        items = [(k, raw, True) for k, raw in parse_overrides(list(overrides)).items()]
    seen: dict[str, str] = {}
    for key, raw, is_text in items:
        for path in resolve_keys(cls, key, aliases):
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


# ------------------------------------------------------------------------ key help
def describe_keys(cls) -> list[str]:
    """One line per leaf key: ``path  type  = default   help`` (for ``run --help``)."""
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
