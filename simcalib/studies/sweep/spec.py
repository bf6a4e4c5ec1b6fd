"""Sweep files: a base scenario plus axes, expanded into cells (full run configs).

A sweep file (YAML, ``scenarios/sweeps/*.yaml`` or any path)::

    description: dqopt vs daniilidis as the pose noise grows, cart and arm
    base: planar                 # scenario name or YAML path (may itself be an axis)
    seed: 0                      # the sweep's seed; every cell's seed derives from it
    seeds: 20                    # replicates of every cell (seed axis)
    set:                         # overrides applied to every cell
      source: noisy
      solvers: [dqopt, daniilidis]
    grid:                        # cartesian product of the lists
      scenario: [planar, 3d]
      noise.sigma_r_deg: [0.1, 0.3, 1.0]
    zip:                         # lists of one length, advanced together
      noise.sigma_t_m: [0.001, 0.003, 0.01]
      pairing.n_pairs: [20, 50, 100]
    random:                      # `samples` draws from distributions
      samples: 10
      keys:
        noise.sigma_r_deg: {distribution: loguniform, low: 0.05, high: 2.0}
        pairing.step: {distribution: choice, values: [1, 2, 5]}

The cells are ``grid × zip × random draws × seeds`` (each block optional). Every cell is a
complete run configuration built by the one config engine (:func:`simcalib.config.
load_configs`): the same typed keys, closest-match errors and range checks as ``run``,
checked for every cell before any work.

Seeds: a cell's run seed is derived from the sweep seed and the cell's swept values (plus
its replicate index), never from its position, so it is the same whatever the executor,
the number of workers or the order of completion. Cells are keyed by a hash of their
resolved configuration (output paths and progress flags excluded): re-running a sweep
skips the finished cells.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from simcalib.errors import ConfigError, did_you_mean

__all__ = ["SweepSpec", "Cell", "load_sweep", "expand", "sweep_dir", "list_sweeps",
           "cell_key", "DISTRIBUTIONS"]

_TOP_KEYS = ("description", "base", "seed", "seeds", "set", "grid", "zip", "random",
             "record")
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "choice", "randint")
#: keys of a resolved run config that do not change its results (excluded from the key)
_NOT_IN_KEY = ("output", "overwrite", "progress", "workers", "recording")


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep file (see the module docstring)."""
    name: str
    base: str
    description: str = ""
    seed: int = 0
    seeds: int = 1
    set: Mapping[str, Any] = field(default_factory=dict)
    grid: Mapping[str, list] = field(default_factory=dict)
    zip: Mapping[str, list] = field(default_factory=dict)
    random_samples: int = 0
    random: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    record_cells: tuple[int, ...] = ()     # cell indices whose recording is kept
    record_worst: int = 0                  # also keep the N worst cells' recordings
    source: str = ""                       # the file it came from

    @property
    def axes(self) -> tuple[str, ...]:
        """The swept keys, in the order grid, zip, random (seed excluded)."""
        return tuple(self.grid) + tuple(self.zip) + tuple(self.random)


@dataclass(frozen=True)
class Cell:
    """One run of a sweep: ``index`` in expansion order, ``values`` the swept keys' values,
    ``replicate`` the seed index, ``seed`` the run's derived seed, ``overrides`` every
    override applied to the base (set + values + seed), ``key`` the hash of the resolved
    config (filled by :func:`simcalib.studies.sweep.runner.resolve_cells`)."""
    index: int
    values: Mapping[str, Any]
    replicate: int
    seed: int
    overrides: Mapping[str, Any]
    key: str = ""


# ------------------------------------------------------------------------ reading files
def sweep_dir() -> Path:
    from simcalib.pipeline.scenario import scenario_dir
    return scenario_dir() / "sweeps"


def list_sweeps() -> dict[str, str]:
    """Shipped sweep files: name -> description."""
    from simcalib.config.files import describe_yaml_files
    return describe_yaml_files(sweep_dir())


def _sweep_path(name: str) -> Path:
    from simcalib.config.files import find_yaml
    return find_yaml(name, sweep_dir(), "sweep")


def load_sweep(name_or_path: str | Mapping, overrides: Mapping[str, Any] | None = None
               ) -> SweepSpec:
    """Parse a sweep file (name of a shipped sweep, a path, or a mapping). ``overrides``
    (dotted run keys -> values) are added to the file's ``set`` block, except the sweep's
    own keys ``seed`` and ``seeds`` which replace the file's."""
    data, name, source = _read_sweep(name_or_path)
    sets = dict(_mapping(data.get("set"), "set"))
    for k, v in dict(overrides or {}).items():
        if k in ("seed", "seeds"):
            data[k] = v
        else:
            sets[k] = v
    if "base" not in data and "scenario" not in sets and "scenario" not in dict(
            data.get("grid") or {}):
        raise ConfigError("sweep: 'base' (the scenario every cell starts from) is required")
    grid = {k: _list(v, f"grid.{k}") for k, v in _mapping(data.get("grid"), "grid").items()}
    zipped = _zipped(data)
    samples, keys = _random_axes(data)
    dup = [k for k in set(grid) | set(zipped) | set(keys)
           if (k in grid) + (k in zipped) + (k in keys) > 1 or k in sets]
    if dup:
        raise ConfigError(f"sweep: key(s) {sorted(dup)} appear in more than one of set/grid/"
                          f"zip/random; a key is either fixed or swept once")
    rec = _mapping(data.get("record"), "record")
    bad = set(rec) - {"cells", "worst"}
    if bad:
        raise ConfigError(f"sweep: record takes 'cells' (indices) and 'worst' (a count); "
                          f"received {sorted(bad)}")
    return SweepSpec(
        name=name, base=str(data.get("base", sets.get("scenario", ""))),
        description=str(data.get("description", "")).strip(),
        seed=_int(data.get("seed", 0), "seed", lo=0), seeds=_int(data.get("seeds", 1),
                                                                   "seeds", lo=1),
        set=sets, grid=grid, zip=zipped, random_samples=samples, random=keys,
        record_cells=tuple(_int(i, "record.cells[]", lo=0) for i in
                           _list(rec.get("cells", []), "record.cells", allow_empty=True)),
        record_worst=_int(rec.get("worst", 0), "record.worst", lo=0), source=source)


def _read_sweep(name_or_path) -> tuple[dict, str, str]:
    """``(data, name, source)`` of a sweep given as a mapping, a shipped name or a path;
    its top-level keys checked."""
    import yaml
    if isinstance(name_or_path, Mapping):
        data, name, source = dict(name_or_path), "sweep", ""
    else:
        path = _sweep_path(str(name_or_path))
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError as exc:
            from simcalib.config.files import _yaml_error_text
            raise ConfigError(f"sweep file {path}: {_yaml_error_text(exc)}") from None
        name, source = path.stem, str(path)
    if not isinstance(data, Mapping):
        raise ConfigError(f"a sweep file must be a mapping of {', '.join(_TOP_KEYS)}; "
                          f"received {type(data).__name__}")
    data = dict(data)
    for key in data:
        if key not in _TOP_KEYS:
            raise ConfigError(f"sweep: unknown key {key!r}{did_you_mean(key, _TOP_KEYS)}; "
                              f"allowed: {', '.join(_TOP_KEYS)}")
    return data, name, source


def _zipped(data: dict) -> dict:
    """The ``zip`` axes: lists of one length, swept together."""
    zipped = {k: _list(v, f"zip.{k}") for k, v in _mapping(data.get("zip"), "zip").items()}
    lengths = {len(v) for v in zipped.values()}
    if len(lengths) > 1:
        raise ConfigError("sweep: the lists under 'zip' must have one length; received "
                          + ", ".join(f"{k}: {len(v)}" for k, v in zipped.items()))
    return zipped


def _random_axes(data: dict) -> tuple[int, dict]:
    """``(samples, keys)`` of the ``random`` block (0 and {} without one)."""
    rnd = _mapping(data.get("random"), "random")
    if not rnd:
        return 0, {}
    unknown = set(rnd) - {"samples", "keys"}
    if unknown:
        raise ConfigError(f"sweep: random takes 'samples' and 'keys'; received "
                          f"{sorted(unknown)}")
    samples = _int(rnd.get("samples"), "random.samples", lo=1)
    keys = {k: _distribution(v, f"random.keys.{k}")
            for k, v in _mapping(rnd.get("keys"), "random.keys").items()}
    if not keys:
        raise ConfigError("sweep: random.keys is empty; name at least one key with its "
                          "distribution")
    return samples, keys


def _mapping(value, key) -> Mapping:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ConfigError(f"sweep: {key} must be a mapping of dotted keys; received "
                          f"{type(value).__name__} {value!r}")
    return value


def _list(value, key, allow_empty=False) -> list:
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f"sweep: {key} must be a list of values; received {value!r}")
    if not value and not allow_empty:
        raise ConfigError(f"sweep: {key} is an empty list; give at least one value")
    return list(value)


def _int(value, key, lo=None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ConfigError(f"sweep: {key} must be an integer; received {value!r}")
    if lo is not None and value < lo:
        raise ConfigError(f"sweep: {key} must be >= {lo}; received {value!r}")
    return int(value)


def _distribution(spec, key) -> dict:
    spec = dict(_mapping(spec, key))
    dist = spec.get("distribution")
    if dist not in DISTRIBUTIONS:
        raise ConfigError(f"sweep: {key}.distribution must be one of "
                          f"{', '.join(DISTRIBUTIONS)}; received {dist!r}"
                          f"{did_you_mean(dist, DISTRIBUTIONS)}")
    need = {"uniform": ("low", "high"), "loguniform": ("low", "high"),
            "normal": ("mean", "std"), "choice": ("values",), "randint": ("low", "high")}[dist]
    missing = [n for n in need if n not in spec]
    extra = sorted(set(spec) - set(need) - {"distribution"})
    if missing or extra:
        raise ConfigError(f"sweep: {key} ({dist}) takes {', '.join(need)}; "
                          f"missing {missing}, unknown {extra}")
    if dist == "choice":
        _list(spec["values"], f"{key}.values")
    else:
        for n in need:
            v = spec[n]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise ConfigError(f"sweep: {key}.{n} must be a finite number; received {v!r}")
        if dist in ("uniform", "loguniform", "randint") and not spec["low"] < spec["high"]:
            raise ConfigError(f"sweep: {key} needs low < high; received low={spec['low']!r}, "
                              f"high={spec['high']!r}")
        if dist == "loguniform" and spec["low"] <= 0:
            raise ConfigError(f"sweep: {key} (loguniform) needs low > 0; received "
                              f"{spec['low']!r}")
        if dist == "normal" and spec["std"] < 0:
            raise ConfigError(f"sweep: {key}.std must be >= 0; received {spec['std']!r}")
    return spec


# ---------------------------------------------------------------------------- expansion
def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, default=_plain, separators=(",", ":"))


def _plain(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)


def derived_seed(sweep_seed: int, values: Mapping[str, Any], replicate: int) -> int:
    """The run seed of a cell: a hash of the sweep seed, the swept values and the replicate
    index (independent of cell order, executor and workers)."""
    text = f"{int(sweep_seed)}|{_canonical(dict(values))}|{int(replicate)}"
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


def _draw(spec: Mapping, rng: np.random.Generator):
    dist = spec["distribution"]
    if dist == "uniform":
        return float(rng.uniform(spec["low"], spec["high"]))
    if dist == "loguniform":
        return float(np.exp(rng.uniform(np.log(spec["low"]), np.log(spec["high"]))))
    if dist == "normal":
        return float(rng.normal(spec["mean"], spec["std"]))
    if dist == "randint":
        return int(rng.integers(int(spec["low"]), int(spec["high"]), endpoint=True))
    values = list(spec["values"])
    return values[int(rng.integers(len(values)))]


def expand(spec: SweepSpec) -> list[Cell]:
    """Every cell of the sweep, in a fixed order (grid, then zip, then random draws, then
    replicates). Random draws come from a Generator seeded by the sweep seed."""
    grid_keys = list(spec.grid)
    grid_rows = [dict(zip(grid_keys, combo))
                 for combo in itertools.product(*(spec.grid[k] for k in grid_keys))] or [{}]
    zip_keys = list(spec.zip)
    n_zip = len(next(iter(spec.zip.values()))) if spec.zip else 0
    zip_rows = [{k: spec.zip[k][i] for k in zip_keys} for i in range(n_zip)] or [{}]
    rnd_rows: list[dict] = [{}]
    if spec.random:
        rng = np.random.default_rng(np.random.SeedSequence([int(spec.seed), 0x5EE9]))
        rnd_rows = [{k: _draw(d, rng) for k, d in spec.random.items()}
                    for _ in range(spec.random_samples)]
    cells = []
    for g, z, r in itertools.product(grid_rows, zip_rows, rnd_rows):
        values = {**g, **z, **r}
        for rep in range(spec.seeds):
            seed = derived_seed(spec.seed, values, rep)
            overrides = {**dict(spec.set), **values, "seed": seed}
            cells.append(Cell(index=len(cells), values=values, replicate=rep, seed=seed,
                              overrides=overrides))
    return cells


def cell_key(config_dict: Mapping) -> str:
    """16 hex characters of the SHA-256 of a resolved configuration (as ``to_dict``),
    without the keys that do not change results (output, overwrite, progress, workers,
    recording)."""
    data = {k: v for k, v in dict(config_dict).items() if k not in _NOT_IN_KEY}
    return hashlib.sha256(_canonical(data).encode()).hexdigest()[:16]
