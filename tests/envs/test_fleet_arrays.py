"""The lock-step fleet's array form: the same episode as its dicts, robot by robot, and its
safety measures in the infos."""

import numpy as np
import pytest

from warehouse_phys.envs import fleet


@pytest.mark.parametrize(
    "kwargs",
    [
        {"num_robots": 6, "grid_rows": 6, "grid_cols": 7, "lifelong": True},
        {"num_robots": 5, "grid_rows": 5, "grid_cols": 6, "on_delivery": "park"},
        {"num_robots": 5, "grid_rows": 5, "grid_cols": 6, "on_delivery": "leave",
         "observation": "neighbours"},
        {"num_robots": 6, "layout": "aisles", "physics": True, "lifelong": True},
        {"num_robots": 4, "layout": "aisles", "physics": True, "moves": "rotate",
         "on_delivery": "park", "physics_threads": 2},
        {"num_robots": 3, "grid_rows": 4, "grid_cols": 5, "observation": "global"},
    ],
)  # fmt: skip
def test_the_array_form_runs_the_same_episode_as_the_dicts(kwargs):
    dicts, arrays = fleet.parallel_env(**kwargs), fleet.parallel_env(**kwargs)
    observations, infos = dicts.reset(seed=2)
    table, columns = arrays.reset_arrays(seed=2)
    rng = np.random.default_rng(2)
    count = dicts.action_space("robot_0").n
    index = list(range(dicts.num_robots))  # the robots the last dicts were about
    for _ in range(40):
        assert np.array_equal(np.stack(list(observations.values())), table[index])
        for key, column in columns.items():
            assert [info[key] for info in infos.values()] == column[index].tolist(), key
        if not dicts.agents:
            break
        index = [dicts.possible_agents.index(agent) for agent in dicts.agents]
        actions = rng.integers(count, size=dicts.num_robots)
        live = dict(zip(dicts.agents, actions[index].tolist(), strict=True))
        observations, rewards, terminations, truncations, infos = dicts.step(live)
        step = arrays.step_arrays(actions)
        table, columns = step.observations, step.infos
        assert list(rewards.values()) == step.rewards[index].tolist()
        assert list(terminations.values()) == step.terminations[index].tolist()
        assert list(truncations.values()) == step.truncations[index].tolist()
        assert np.array_equal(dicts.robot_cells, arrays.robot_cells)
        assert dicts.agents == arrays.agents
        gone = np.setdiff1d(np.arange(dicts.num_robots), index)
        assert step.terminations[gone].all()
        assert not step.rewards[gone].any()
    if kwargs.get("physics"):
        assert arrays.safety.summary() == dicts.safety.summary()
        assert dicts.safety.steps > 0
        assert {"closest_approach", "body_contacts", "wall_contacts"} <= set(columns)
        assert (columns["closest_approach"] >= dicts.safety.bound).all()


def test_the_fleet_refuses_reset_options_but_pettingzoos_probe():
    env = fleet.parallel_env(num_robots=2)
    with pytest.raises(ValueError, match=r"unknown reset option\(s\) 'x'; known: none"):
        env.reset(options={"x": 1})
    with pytest.raises(TypeError, match="reset options must be a dict or None"):
        env.reset(options="x")
    env.reset(seed=0, options={"options": 1})  # what PettingZoo's API test passes


def test_a_bad_action_array_is_refused_naming_the_robot_and_nothing_changes():
    env = fleet.parallel_env(num_robots=3)
    env.reset(seed=0)
    cells = env.robot_cells.copy()
    with pytest.raises(ValueError, match=r"actions must be 0..4 \(4 is WAIT\): robot_2 got 5"):
        env.step_arrays(np.array([0, 1, 5]))
    with pytest.raises(ValueError, match=r"actions must have shape \(3,\)"):
        env.step_arrays(np.array([0, 1]))
    assert np.array_equal(env.robot_cells, cells)
    assert env.steps == 0
