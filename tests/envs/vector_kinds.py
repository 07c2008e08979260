"""The two native vector envs, the grid twin and the physics twin, as the shared tests see them:
their floors, how long each test runs them, and the helpers that record, replay and compare."""

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

import warehouse_phys
from warehouse_phys import SNAP_ERROR_BOUND
from warehouse_phys.envs.vector import WarehouseGridVectorEnv
from warehouse_phys.envs.vector_physics import WarehousePhysicsVectorEnv

GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID
SHELVES = ["S..#...", ".#.#.#.", ".#...#P", "...#..."]
#: Floor name: (gym id, keywords).
GRID_FLOORS = {
    "default": (GRID_ID, {}),
    "6x7": (GRID_ID, {"grid_rows": 6, "grid_cols": 7, "max_episode_steps": 40}),
    **{name: (warehouse_phys.preset_ids(name)[0], {}) for name in warehouse_phys.PRESETS},
    "shelves": (GRID_ID, {"layout": SHELVES, "max_episode_steps": 25}),
}
PHYS_FLOORS = {
    "default": (PHYS_ID, {"max_episode_steps": 12}),  # short: truncations and autoresets
    **{name: (warehouse_phys.preset_ids(name)[1], {}) for name in warehouse_phys.PRESETS},
}
#: Body positions may differ from the single environment's by no more than this [cells].
TOLERANCE = 1e-9


@dataclass(frozen=True)
class Kind:
    """One native vector env and how long the shared tests run it (a physics step costs more)."""

    name: str
    env_id: str
    vector_class: type
    floors: dict[str, tuple[str, dict[str, Any]]]
    #: The infos given per floor, each with its ``_`` mask.
    info_keys: tuple[str, ...]
    #: Keywords that make the env record its robots' paths (none for the grid).
    record: dict[str, Any]
    #: The replay proof: steps recorded for each ``num_envs``.
    replay_steps: dict[int, int]
    #: Floors whose replay must cross an autoreset.
    autoreset_floors: tuple[str, ...]
    #: Determinism: ``(num_envs, steps, keywords)``.
    trajectory: tuple[int, int, dict[str, Any]]
    #: Copies: ``(num_envs, steps before copying, steps compared, keywords)``.
    copies: tuple[int, int, int, dict[str, Any]]

    @property
    def physics(self) -> bool:
        return self.vector_class is WarehousePhysicsVectorEnv


GRID = Kind(
    name="grid",
    env_id=GRID_ID,
    vector_class=WarehouseGridVectorEnv,
    floors=GRID_FLOORS,
    info_keys=("optimal_steps",),
    record={},
    replay_steps={1: 2000, 7: 1000, 64: 200},
    autoreset_floors=("6x7", "shelves", "default"),
    trajectory=(16, 300, {"grid_rows": 5, "grid_cols": 6}),
    copies=(8, 30, 100, {}),
)
PHYS = Kind(
    name="phys",
    env_id=PHYS_ID,
    vector_class=WarehousePhysicsVectorEnv,
    floors=PHYS_FLOORS,
    info_keys=("optimal_steps", "snap_error"),
    record={"record_path": True},
    replay_steps={1: 300, 5: 120, 64: 40},
    autoreset_floors=("default",),
    trajectory=(12, 60, {"record_path": True, "max_episode_steps": 20}),
    copies=(6, 25, 40, {"record_path": True, "max_episode_steps": 10}),
)
KINDS = {kind.name: kind for kind in (GRID, PHYS)}


def assert_same_steps(a, b, *info_keys):
    """Two ``step`` results agree: observations, rewards, endings and the named infos."""
    for x, y in zip(a[:4], b[:4], strict=True):
        assert np.array_equal(x, y)
    for key in info_keys:
        assert np.array_equal(a[4][key], b[4][key])


# --------------------------------------------------------------- the replay proof
def record_episodes(envs, n_steps, seed):
    """Run random actions; return every sub-environment's episodes as (target, reset info,
    [(action, obs, reward, terminated, truncated, optimal_steps, path)]); the path is the
    robot's recorded move on the physics twin, None on the grid."""
    physics = isinstance(envs, WarehousePhysicsVectorEnv)
    rng = np.random.default_rng(seed)
    obs, infos = envs.reset(seed=seed)
    n = envs.num_envs
    episodes = [[] for _ in range(n)]
    current = [(tuple(o[2:]), int(i), []) for o, i in zip(obs, infos["optimal_steps"], strict=True)]
    restarting = np.zeros(n, dtype=bool)
    paths = [None] * n
    for _ in range(n_steps):
        actions = rng.integers(4, size=n)
        obs, rewards, terminated, truncated, infos = envs.step(actions)
        assert infos["_optimal_steps"].all()
        if physics:
            paths = envs.last_move_paths
            assert paths.shape == (n, envs.physics.steps_per_move, 2)
            assert infos["_snap_error"].all()
            assert (infos["snap_error"] < SNAP_ERROR_BOUND).all()
        for i in range(n):
            if restarting[i]:  # this step started a new episode and ignored the action
                assert (rewards[i], terminated[i], truncated[i]) == (0.0, False, False)
                if physics:
                    assert infos["snap_error"][i] == 0.0
                    assert (paths[i] == obs[i, :2]).all()  # it stood on the start
                episodes[i].append(current[i])
                current[i] = (tuple(obs[i, 2:]), int(infos["optimal_steps"][i]), [])
            else:
                current[i][2].append((int(actions[i]), obs[i].copy(), rewards[i], terminated[i],
                                      truncated[i], int(infos["optimal_steps"][i]),
                                      paths[i]))  # fmt: skip
        restarting = terminated | truncated
    for i in range(n):
        episodes[i].append(current[i])
    return episodes


def replay(kind, env_id, kwargs, episodes):
    """Replay each episode in a single environment; the steps replayed and the largest
    difference in position along the recorded paths (0 on the grid, which has none)."""
    env = gym.make(env_id, **kind.record, **kwargs)
    steps, worst = 0, 0.0
    for per_env in episodes:
        for target, optimal, transitions in per_env:
            obs, info = env.reset(options={"target": target})
            assert tuple(obs[2:]) == target
            assert tuple(obs[:2]) == tuple(env.unwrapped.grid.start)
            assert info["optimal_steps"] == optimal
            for action, v_obs, v_reward, v_term, v_trunc, v_optimal, v_path in transitions:
                obs, reward, terminated, truncated, info = env.step(action)
                assert np.array_equal(obs, v_obs)
                assert (reward, terminated, truncated) == (v_reward, v_term, v_trunc)
                assert info["optimal_steps"] == v_optimal
                if v_path is not None:
                    worst = max(worst, np.abs(env.unwrapped.last_move_path - v_path).max())
                steps += 1
    return steps, worst


# ------------------------------------------------------------------ determinism
def trajectory_bytes(kind_name, seed):
    """Everything a seeded run of random actions gives, as bytes (paths included where
    recorded); also run in a fresh process, hence named by the kind's name."""
    kind = KINDS[kind_name]
    num_envs, n_steps, kwargs = kind.trajectory
    envs = gym.make_vec(kind.env_id, num_envs=num_envs, **kwargs)
    rng = np.random.default_rng(99)
    out = [envs.reset(seed=seed)[0].tobytes()]
    for _ in range(n_steps):
        obs, rewards, terminated, truncated, infos = envs.step(rng.integers(4, size=num_envs))
        out += [obs.tobytes(), rewards.tobytes(), terminated.tobytes(), truncated.tobytes()]
        out += [infos[key].tobytes() for key in kind.info_keys]
        if kind.physics:
            out.append(envs.last_move_paths.tobytes())
    return b"".join(out)
