"""Executors: every registered executor gives the results of a plain loop (each task has
its own seed), reports a failing task as its exception, and is found by the registry."""

import numpy as np
import pytest

from simcalib.errors import ConfigError
from simcalib.executors import available, get


def seeded_draw(seed: int, n: int):
    """A module-level task (picklable): a result that depends on its seed only."""
    if n < 0:
        raise ValueError(f"n must be >= 0; received {n}")
    return float(np.random.default_rng(seed).standard_normal(n).sum())


TASKS = [(seed, 50 + seed) for seed in range(6)]


def _usable(name):
    if available()[name].extra:
        # an executor with an extra dependency runs tasks on other machines: its workers
        # import the task from simcalib (PYTHONPATH), not from tests/; the sweep test
        # (test_studies_sweep.py, slow) compares its tables with the local ones
        pytest.skip(f"executor={name} ([{available()[name].extra}]) is compared in "
                    "test_studies_sweep.py")


@pytest.mark.parametrize("name", list(available()))
def test_every_executor_matches_a_plain_loop(name):
    _usable(name)
    expected = {i: seeded_draw(*t) for i, t in enumerate(TASKS)}
    ex = get(name)
    assert ex.name == name
    got = dict(ex.map(seeded_draw, TASKS, 2))
    assert got == expected


@pytest.mark.parametrize("name", list(available()))
def test_a_failing_task_is_yielded_as_its_exception(name):
    _usable(name)
    got = dict(get(name).map(seeded_draw, [(1, 3), (2, -1)], 2))
    assert isinstance(got[1], ValueError) and "received -1" in str(got[1])
    assert got[0] == seeded_draw(1, 3)


def test_registry_describes_each_executor_and_rejects_unknown_names():
    infos = available()
    assert infos and all(i.name == n and i.description for n, i in infos.items())
    with pytest.raises(ConfigError) as exc:
        get("thread")
    msg = str(exc.value)
    assert "unknown executor 'thread'" in msg and all(n in msg for n in infos)
