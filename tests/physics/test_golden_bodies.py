"""The physics twin's bodies follow their golden runs bit for bit, in lock step and on
ticks, for both move models (``tests/physics/golden_bodies.py``), whether the bodies are
held in one space or split into regions stepped in parallel threads (no two bodies touch
in these runs, so every number of threads gives the one-space bits)."""

import numpy as np
import pytest

from tests.physics.golden_bodies import (
    LOCKSTEP_SCENARIOS,
    TICK_SCENARIOS,
    golden,
    run_lockstep,
    run_ticks,
)

THREADS = [1, 2]  # three threads: tests/physics/test_regions.py


def _first_divergence(expected: np.ndarray, actual: np.ndarray) -> int | None:
    for index, (want, got) in enumerate(zip(expected, actual, strict=False)):
        if want.tobytes() != got.tobytes():
            return index
    return None if len(expected) == len(actual) else min(len(expected), len(actual))


def _assert_replayed(name: str, actual: dict[str, np.ndarray]) -> None:
    expected = golden(name)
    assert sorted(actual) == sorted(expected)
    at = _first_divergence(expected["digests"], actual["digests"])
    assert at is None, f"{name}: the bodies leave their recorded course at step {at}"
    for key, value in expected.items():
        assert actual[key].tobytes() == value.tobytes(), key


@pytest.mark.parametrize("threads", THREADS)
@pytest.mark.parametrize(("name", "kwargs", "ticks"), TICK_SCENARIOS,
                         ids=[s[0] for s in TICK_SCENARIOS])  # fmt: skip
def test_the_bodies_on_ticks_replay_their_golden_run(name, kwargs, ticks, threads):
    _assert_replayed(name, run_ticks(kwargs, ticks, physics_threads=threads))


@pytest.mark.parametrize("threads", THREADS)
@pytest.mark.parametrize(("name", "kwargs", "steps"), LOCKSTEP_SCENARIOS,
                         ids=[s[0] for s in LOCKSTEP_SCENARIOS])  # fmt: skip
def test_the_bodies_in_lock_step_replay_their_golden_run(name, kwargs, steps, threads):
    _assert_replayed(name, run_lockstep(kwargs, steps, physics_threads=threads))
