"""Golden trajectories: what the single environments did before their hot paths were tuned.

``python -m tests.envs.golden`` records them into ``tests/envs/golden_trajectories.npz``;
``tests/envs/test_golden.py`` checks that the environments still produce them bit for
bit. Regenerate only for an intended change of behaviour, and say so in the commit.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

import warehouse_phys  # noqa: F401 - registers the ids

GOLDEN_FILE = Path(__file__).resolve().parent / "golden_trajectories.npz"
#: (name, env id, kwargs, seed, actions)
SCENARIOS = [
    ("grid", "warehouse-robot-v0", {}, 1, 3000),
    ("grid_maze", "warehouse-robot-maze-v0", {}, 2, 3000),
    ("grid_6x7", "warehouse-robot-v0", {"grid_rows": 6, "grid_cols": 7}, 3, 3000),
    ("phys", "warehouse-robot-phys-v0", {"record_path": True}, 4, 600),
    ("phys_maze", "warehouse-robot-phys-maze-v0", {"record_path": True}, 5, 600),
]


def run(env_id: str, kwargs: dict, seed: int, n_actions: int) -> dict[str, np.ndarray]:
    """Random actions (from their own seeded generator), resetting at episode ends."""
    env = gym.make(env_id, max_episode_steps=50, **kwargs)
    actions = np.random.default_rng(seed + 1000).integers(4, size=n_actions)
    obs, info = env.reset(seed=seed)
    record: dict[str, list] = {k: [] for k in ("obs", "reward", "terminated", "truncated",
                                               "optimal_steps", "snap_error", "path")}  # fmt: skip
    record["obs"].append(obs)
    record["optimal_steps"].append(info["optimal_steps"])
    for action in actions.tolist():
        obs, reward, terminated, truncated, info = env.step(action)
        record["obs"].append(obs)
        record["reward"].append(reward)
        record["terminated"].append(terminated)
        record["truncated"].append(truncated)
        record["optimal_steps"].append(info["optimal_steps"])
        if "snap_error" in info:
            record["snap_error"].append(info["snap_error"])
            record["path"].append(env.unwrapped.last_move_path)
        if terminated or truncated:
            obs, info = env.reset()
            record["obs"].append(obs)
            record["optimal_steps"].append(info["optimal_steps"])
    return {
        key: np.array(values, dtype=np.float64 if key in ("reward", "snap_error") else None)
        for key, values in record.items()
    }


def record_all() -> dict[str, np.ndarray]:
    arrays = {}
    for name, env_id, kwargs, seed, n_actions in SCENARIOS:
        for key, value in run(env_id, kwargs, seed, n_actions).items():
            arrays[f"{name}/{key}"] = value
    return arrays


if __name__ == "__main__":
    np.savez_compressed(GOLDEN_FILE, **record_all())
    print(f"wrote {GOLDEN_FILE}")
