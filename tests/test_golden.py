"""The single environments still produce their golden trajectories, bit for bit."""

import numpy as np
import pytest

from tests.golden import GOLDEN_FILE, SCENARIOS, run


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
