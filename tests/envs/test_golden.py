"""The single environments, the physics fleet and the physics vector env still produce
their golden runs, bit for bit."""

import numpy as np
import pytest

from tests.envs.golden import GOLDEN_FILE, SCENARIOS, run
from tests.envs.golden_physics import FLEET_SCENARIOS, VECTOR_SCENARIOS, run_fleet, run_vector
from tests.envs.golden_physics import GOLDEN_FILE as GOLDEN_PHYSICS_FILE
from warehouse_phys.physics import batched as batched_physics
from warehouse_phys.physics import body_io


@pytest.mark.parametrize(("name", "env_id", "kwargs", "seed", "n_actions"), SCENARIOS,
                         ids=[s[0] for s in SCENARIOS])  # fmt: skip
def test_the_environment_replays_its_golden_trajectory(name, env_id, kwargs, seed, n_actions):
    with np.load(GOLDEN_FILE) as golden:
        expected = {key.split("/", 1)[1]: golden[key] for key in golden.files
                    if key.startswith(f"{name}/")}  # fmt: skip
    actual = run(env_id, kwargs, seed, n_actions)
    assert sorted(actual) == sorted(expected)
    for key, value in expected.items():
        assert actual[key].dtype == value.dtype, key
        assert actual[key].tobytes() == value.tobytes(), key


def _assert_bit_identical(expected: dict, actual: dict, keys: list[str]) -> None:
    for key in keys:
        assert actual[key].tobytes() == expected[key].tobytes(), key


def _golden(name: str) -> dict[str, np.ndarray]:
    with np.load(GOLDEN_PHYSICS_FILE) as golden:
        return {key.split("/", 1)[1]: golden[key] for key in golden.files
                if key.startswith(f"{name}/")}  # fmt: skip


@pytest.mark.parametrize(("name", "kwargs", "seeds", "steps"), FLEET_SCENARIOS,
                         ids=[s[0] for s in FLEET_SCENARIOS])  # fmt: skip
def test_the_physics_fleet_replays_its_golden_run(name, kwargs, seeds, steps):
    expected = _golden(name)
    actual = run_fleet(kwargs, seeds, steps)
    assert sorted(actual) == sorted(expected)
    _assert_bit_identical(expected, actual, [key for key in expected if key != "min_gap"])
    # min_gap was recorded over every pair, and is now over the robots within reach: every
    # approach closer than sqrt(2) - d (the closest two robots out of reach can come) is
    # exact; -1 marks a robot done, without infos.
    recorded, measured = expected["min_gap"], actual["min_gap"]
    close = recorded < 0.8
    assert measured[close].tobytes() == recorded[close].tobytes()
    assert (measured[~close] >= recorded[~close]).all()  # farther: a subset's minimum
    assert close.any()


@pytest.mark.parametrize(("name", "num_envs", "seed", "steps"), VECTOR_SCENARIOS,
                         ids=[s[0] for s in VECTOR_SCENARIOS])  # fmt: skip
def test_the_physics_vector_env_replays_its_golden_run(name, num_envs, seed, steps):
    expected = _golden(name)
    actual = run_vector(num_envs, seed, steps)
    assert sorted(actual) == sorted(expected)
    _assert_bit_identical(expected, actual, list(expected))


def test_without_pymunks_internals_the_physics_worlds_restart_alike(monkeypatch):
    """Where pymunk's internals are out of reach, a restart cannot clear the space's last
    time step: with every joint and contact new there is nothing to warm-start, and the
    fleet and the vector env still replay their golden runs."""
    monkeypatch.setattr(batched_physics, "CAN_RESTART", False)

    def cannot(space: object) -> None:
        raise RuntimeError("this pymunk cannot clear a space's time step")

    monkeypatch.setattr(body_io, "clear_time_step", cannot)  # where the world clears it
    name, kwargs, seeds, steps = FLEET_SCENARIOS[0]
    expected = _golden(name)
    trajectory = ["cells", "paths", "snap_error", "reward"]
    _assert_bit_identical(expected, run_fleet(kwargs, seeds, steps), trajectory)
    name, num_envs, seed, steps = VECTOR_SCENARIOS[0]
    expected = _golden(name)
    _assert_bit_identical(expected, run_vector(num_envs, seed, steps), list(expected))
