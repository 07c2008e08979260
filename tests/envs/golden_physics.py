"""Golden runs of the physics fleet and the physics vector env, recorded before their
worlds were made to restart instead of being rebuilt and their gap diagnostic replaced.

``python -m tests.envs.golden_physics`` rewrites ``tests/envs/golden_physics.npz``;
``tests/envs/test_golden.py`` checks that both still produce these runs bit for bit. The
recorded ``min_gap`` is the all-pairs value of the code before the change (the test
holds today's, over the robots within reach, to it for every close approach); a new
recording would record today's. Regenerate only for an intended change of behaviour,
and say so in the commit.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

import warehouse_phys  # noqa: F401 - registers the ids
from warehouse_phys.envs import fleet

GOLDEN_FILE = Path(__file__).resolve().parent / "golden_physics.npz"

#: (name, fleet keywords, seeds of the episodes, joint steps per episode)
FLEET_SCENARIOS = [
    ("fleet_lifelong", {"num_robots": 8, "grid_rows": 8, "grid_cols": 10, "lifelong": True},
     (7, 8, None), 60),
    ("fleet_park", {"num_robots": 4}, (11, None, 12), 40),
]  # fmt: skip
#: (name, number of environments, seed, steps)
VECTOR_SCENARIOS = [("vector", 5, 21, 200)]


def run_fleet(kwargs: dict, seeds: tuple, steps: int) -> dict[str, np.ndarray]:
    """Random joint actions (their own generator), a reset with each seed in turn."""
    env = fleet.parallel_env(physics=True, max_cycles=steps, **kwargs)
    rng = np.random.default_rng(1000)
    record: dict[str, list] = {key: [] for key in ("cells", "reward", "snap_error", "min_gap",
                                                   "paths", "episode_ends")}  # fmt: skip
    for seed in seeds:
        env.reset(seed=seed)
        record["cells"].append(env.robot_cells.copy())
        while env.agents:
            actions = {agent: int(rng.integers(5)) for agent in env.agents}
            _, rewards, _, _, infos = env.step(actions)
            record["cells"].append(env.robot_cells.copy())
            n = env.num_robots
            reward, snap, gap = np.zeros(n), np.full(n, -1.0), np.full(n, -1.0)
            for agent, info in infos.items():
                index = env.possible_agents.index(agent)
                reward[index] = rewards[agent]
                snap[index], gap[index] = info["snap_error"], info["min_gap"]
            record["reward"].append(reward)
            record["snap_error"].append(snap)
            record["min_gap"].append(gap)
            record["paths"].append(env.world.last_paths)
        record["episode_ends"].append(len(record["cells"]))
    return {key: np.array(values) for key, values in record.items()}


def run_vector(num_envs: int, seed: int, steps: int) -> dict[str, np.ndarray]:
    """Random actions on the native physics vector env, autoreset included."""
    envs = gym.make_vec("warehouse-robot-phys-v0", num_envs=num_envs, max_episode_steps=30)
    actions = np.random.default_rng(seed + 1000).integers(4, size=(steps, num_envs))
    obs, info = envs.reset(seed=seed)
    record: dict[str, list] = {"obs": [obs], "snap_error": [info["snap_error"]],
                               "reward": [], "terminated": [], "truncated": []}  # fmt: skip
    for row in actions:
        obs, reward, terminated, truncated, info = envs.step(row)
        for key, value in (
            ("obs", obs),
            ("reward", reward),
            ("terminated", terminated),
            ("truncated", truncated),
            ("snap_error", info["snap_error"]),
        ):
            record[key].append(value)  # fmt: skip
    envs.close()
    return {key: np.array(values) for key, values in record.items()}


def record_all() -> dict[str, np.ndarray]:
    arrays = {}
    for name, kwargs, seeds, steps in FLEET_SCENARIOS:
        for key, value in run_fleet(kwargs, seeds, steps).items():
            arrays[f"{name}/{key}"] = value
    for name, num_envs, seed, steps in VECTOR_SCENARIOS:
        for key, value in run_vector(num_envs, seed, steps).items():
            arrays[f"{name}/{key}"] = value
    return arrays


if __name__ == "__main__":
    np.savez_compressed(GOLDEN_FILE, **record_all())
    print(f"wrote {GOLDEN_FILE}")
