"""Registry of pose sources: lookup by name (unknown names list the valid ones) and the
choice of source per camera for a run.

:data:`SOURCES` is a :class:`simcalib.registry.Registry` over the package
``simcalib.sources``: the first lookup imports every module of that folder, so a new file
that calls :func:`register` at import is found with no import list to edit."""

from __future__ import annotations

import dataclasses

from simcalib.errors import unknown_choice
from simcalib.registry import Registry
from simcalib.sources.base import CAMERAS, PoseSource, SourceInfo

__all__ = ["SOURCES", "register", "get_source", "available_sources", "sources_for_kind",
           "camera_sources"]


def _check_source(name: str, source) -> None:
    info = getattr(source, "info", None)
    if not isinstance(info, SourceInfo) or not callable(getattr(source, "measure", None)):
        raise TypeError(f"a pose source needs info: SourceInfo and a measure() method; "
                        f"received {type(source).__name__}")
    if not info.cameras or not set(info.cameras) <= set(CAMERAS):
        raise ValueError(f"pose source {info.name!r}: cameras must be some of "
                         f"{list(CAMERAS)}; received {list(info.cameras)}")
    if info.config is not None and not (isinstance(info.config, type)
                                        and dataclasses.is_dataclass(info.config)):
        raise TypeError(f"pose source {info.name!r}: config must be a dataclass (its "
                        f"section of the scenario); received {info.config!r}")


SOURCES: Registry[PoseSource] = Registry("pose source", key="source",
                                         package="simcalib.sources", check=_check_source)

#: A ground-truth kind whose measurements come from one fixed source whatever ``source``
#: says: synthetic problems carry their noisy motions (``source`` only sets their noise
#: level via ``noise.*``, see ``ScenarioConfig``).
_NATIVE_SOURCE = {"synthetic": "synthetic"}


def register(source: PoseSource) -> PoseSource:
    """Add ``source`` (an object with ``info: SourceInfo`` and ``measure``) under
    ``source.info.name``; a second source of the same name is refused."""
    _check_source("", source)
    return SOURCES.register(source.info.name, source)


def available_sources() -> dict[str, SourceInfo]:
    """name -> :class:`SourceInfo` of every registered source, by name."""
    return dict(sorted(SOURCES.available().items()))


def sources_for_kind(kind: str) -> tuple[str, ...]:
    """Names of the sources that can measure ground truth of ``kind``."""
    return tuple(n for n, i in available_sources().items() if kind in i.kinds)


def get_source(name: str, kind: str | None = None) -> PoseSource:
    """The source ``name``; with ``kind``, also checks it can measure that ground truth."""
    if isinstance(name, str) and name not in SOURCES:     # the valid names listed sorted
        raise unknown_choice("pose source", name, sorted(SOURCES.names()), key="source")
    src = SOURCES.get(name)
    if kind is not None and kind not in src.info.kinds:
        kinds = sorted({k for i in SOURCES.available().values() for k in i.kinds})
        combos = "; ".join(f"{k}: {list(sources_for_kind(k))}" for k in kinds)
        raise ValueError(f"pose source {name!r} cannot measure kind={kind!r} (it needs "
                         f"{list(src.info.kinds)}); valid sources per kind: {combos}")
    return src


def camera_sources(cfg, kind: str) -> dict[str, str]:
    """camera -> source name for a run of ``cfg`` over ground truth of ``kind``.

    Each camera uses its stream's source (``streams.a.source`` / ``streams.b.source``),
    else ``cfg.source``; a kind with a native source (synthetic) always uses it."""
    streams = getattr(cfg, "streams", None)
    if kind in _NATIVE_SOURCE:
        if streams is not None and streams.any_set:
            raise ValueError(f"kind={kind!r} measures with its own source "
                             f"{_NATIVE_SOURCE[kind]!r}; streams.a.source / streams.b.source "
                             "apply to simulated worlds (kind='sim') only")
        name = _NATIVE_SOURCE[kind]
        get_source(name, kind)
        return {cam: name for cam in CAMERAS}
    out = {}
    for cam in CAMERAS:
        name = cfg.source if streams is None else streams.source_of(cam, cfg.source)
        cams = get_source(name, kind).info.cameras
        if cam not in cams:
            from simcalib.errors import ConfigError
            key = f"streams.{cam.removeprefix('cam_')}.source"
            raise ConfigError(f"pose source {name!r} measures {' and '.join(cams)} only; "
                              f"{cam} needs another source ({key}=...)", key=key, value=name)
        out[cam] = name
    return out
