"""Registry of pose sources: lookup by name (unknown names list the valid ones) and the
choice of source per camera for a run."""

from __future__ import annotations

from simcalib.errors import unknown_choice
from simcalib.sources.base import CAMERAS, PoseSource, SourceInfo

__all__ = ["register", "get_source", "available_sources", "sources_for_kind",
           "camera_sources"]

_SOURCES: dict[str, PoseSource] = {}

#: A ground-truth kind whose measurements come from one fixed source whatever ``source``
#: says: synthetic problems carry their noisy motions (``source`` only sets their noise
#: level via ``noise.*``, see ``ScenarioConfig``).
_NATIVE_SOURCE = {"synthetic": "synthetic"}


def register(source: PoseSource) -> PoseSource:
    """Add ``source`` (an object with ``info: SourceInfo`` and ``measure``)."""
    info = getattr(source, "info", None)
    if not isinstance(info, SourceInfo) or not callable(getattr(source, "measure", None)):
        raise TypeError(f"a pose source needs info: SourceInfo and a measure() method; "
                        f"received {type(source).__name__}")
    if info.name in _SOURCES and _SOURCES[info.name] is not source:
        raise ValueError(f"pose source {info.name!r} is already registered")
    _SOURCES[info.name] = source
    return source


def available_sources() -> dict[str, SourceInfo]:
    """name -> :class:`SourceInfo` of every registered source."""
    return {name: s.info for name, s in sorted(_SOURCES.items())}


def sources_for_kind(kind: str) -> tuple[str, ...]:
    """Names of the sources that can measure ground truth of ``kind``."""
    return tuple(n for n, i in available_sources().items() if kind in i.kinds)


def get_source(name: str, kind: str | None = None) -> PoseSource:
    """The source ``name``; with ``kind``, also checks it can measure that ground truth."""
    if not isinstance(name, str):
        raise TypeError(f"source name must be a string; received {type(name).__name__}")
    if name not in _SOURCES:
        raise unknown_choice("pose source", name, sorted(_SOURCES), key="source")
    src = _SOURCES[name]
    if kind is not None and kind not in src.info.kinds:
        combos = "; ".join(f"{k}: {list(sources_for_kind(k))}"
                           for k in sorted({k for s in _SOURCES.values() for k in s.info.kinds}))
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
        get_source(name, kind)
        out[cam] = name
    return out
