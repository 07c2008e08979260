"""Tabular Q-learning for a fleet, and how well a fleet's policy delivers.

Every robot of a :class:`~warehouse_phys.fleet.WarehouseFleetEnv` is an
independent Q-learner, and all of them share one table over the local
observation ``[row, col, package_row, package_col]``: shape ``(R, C, R, C, 5)``,
the four moves and WAIT. :func:`evaluate_fleet` plays a policy over fixed seeds
and reports what traffic costs: packages delivered, the robots' steps against
the sum of their shortest paths, refused moves and deadlocks.
:func:`shortest_path_policy` is the baseline: each robot takes a move along a
shortest path to its package and waits when that cell is taken.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from warehouse_phys.animation import Animation
from warehouse_phys.fleet import WarehouseFleetEnv
from warehouse_phys.layouts import preset_name
from warehouse_phys.qlearning import (
    TABLE_FORMAT,
    TABLE_FORMAT_VERSION,
    QLearningConfig,
    TrainingResult,
    agent_rng,
    check_training_memory,
)
from warehouse_phys.traffic import FLEET_ACTIONS, WAIT

#: A fleet policy: the environment, every live robot's observation and last info -> actions.
FleetPolicy = Callable[
    [WarehouseFleetEnv, dict[str, np.ndarray], dict[str, dict[str, Any]]], dict[str, int]
]


def new_fleet_q_table(rows: int, cols: int) -> np.ndarray:
    """An all-zero float64 table for a fleet on a ``rows`` x ``cols`` floor: ``(R, C, R, C, 5)``."""
    check_training_memory(rows, cols, 0)
    return np.zeros((rows, cols, rows, cols, FLEET_ACTIONS), dtype=np.float64)


def train_fleet(
    env: WarehouseFleetEnv,
    config: QLearningConfig | None = None,
    *,
    on_episode: Callable[[int], None] | None = None,
) -> TrainingResult:
    """Train one shared table with every robot an epsilon-greedy Q-learner.

    The first episode starts with ``env.reset(seed=config.seed)``, later ones
    with ``env.reset()``; exploration draws from
    :func:`~warehouse_phys.qlearning.agent_rng` of the seed, one draw per robot
    in robot order, so a run is reproducible. After each joint step every robot
    that acted updates the table with its own reward and next observation.

    The result's records, per episode, are a fleet's: ``steps`` its joint steps,
    ``returns`` the packages delivered, ``reached_target`` whether every robot
    delivered and ``truncated`` whether the time limit came first.

    Raises:
        ValueError: if ``env`` gives global observations (the table needs the local ones).
    """
    if env.observation != "local":
        raise ValueError("a shared table needs observation='local'")
    config = config or QLearningConfig()
    rows, cols = env.grid.rows, env.grid.cols
    check_training_memory(rows, cols, config.episodes)
    q = new_fleet_q_table(rows, cols)
    rng = agent_rng(config.seed)
    alpha, gamma, episodes = config.alpha, config.gamma, config.episodes
    steps = np.zeros(episodes, dtype=np.int64)
    returns = np.zeros(episodes, dtype=np.float64)
    reached = np.zeros(episodes, dtype=bool)
    truncated_episodes = np.zeros(episodes, dtype=bool)
    epsilons = np.maximum(1.0 - np.arange(episodes) / episodes, 0.0)

    for episode in range(episodes):
        observations, _ = env.reset(seed=config.seed) if episode == 0 else env.reset()
        epsilon, n_steps, total = epsilons[episode], 0, 0.0
        cut = False
        while env.agents:
            states = {agent: tuple(obs.tolist()) for agent, obs in observations.items()}
            actions = {}
            for agent in env.agents:
                if rng.random() < epsilon:
                    actions[agent] = int(rng.integers(FLEET_ACTIONS))
                else:
                    actions[agent] = int(q[states[agent]].argmax())
            observations, rewards, terminations, truncations, _ = env.step(actions)
            for agent, action in actions.items():
                values = q[states[agent]]
                if terminations[agent]:
                    td_target = rewards[agent]
                else:
                    next_values = q[tuple(observations[agent].tolist())]
                    td_target = rewards[agent] + gamma * next_values.max()
                values[action] += alpha * (td_target - values[action])
            n_steps += 1
            total += sum(rewards.values())
            cut = cut or any(truncations.values())
        steps[episode] = n_steps
        returns[episode] = total
        reached[episode] = not cut
        truncated_episodes[episode] = cut
        if on_episode is not None:
            on_episode(episode)
    return TrainingResult(q, config, steps, returns, reached, truncated_episodes, epsilons)


def greedy_fleet_policy(q: np.ndarray) -> FleetPolicy:
    """Every robot takes the shared table's best action for its own observation."""

    def policy(
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        return {agent: int(q[tuple(obs.tolist())].argmax()) for agent, obs in observations.items()}

    return policy


def shortest_path_policy(
    env: WarehouseFleetEnv,
    observations: dict[str, np.ndarray],
    infos: dict[str, dict[str, Any]],
) -> dict[str, int]:
    """Each robot moves along a shortest path to its package (the first such move in
    action order whose cell no robot stands on) and waits when every such cell is taken."""
    grid = env.grid
    state = env.state().reshape(env.num_robots, 4)
    taken = {(int(r), int(c)) for r, c in state[:, :2]}
    actions = {}
    for agent, obs in observations.items():
        row, col, p_row, p_col = (int(v) for v in obs)
        package = (p_row, p_col)
        here = grid.optimal_steps((row, col), package)  # distances are cached per package
        actions[agent] = WAIT
        for action in range(4):
            cell = grid.move((row, col), action)
            if tuple(cell) not in taken and grid.optimal_steps(cell, package) < here:
                actions[agent] = action
                break
    return actions


@dataclass(frozen=True)
class FleetEvaluation:
    """How a policy did over fixed seeds, each episode without lifelong packages."""

    episodes: int
    robots: int
    #: Packages delivered, of ``episodes * robots``.
    delivered: int
    #: Steps each robot took to its package, summed over the robots that delivered.
    robot_steps: int
    #: The same robots' shortest paths at the start, summed: the steps without traffic.
    shortest_steps: int
    #: Moves that traffic turned into waits.
    refused: int
    #: Episodes that the time limit ended with a package undelivered.
    deadlocks: int

    @property
    def delay(self) -> int:
        """Steps that traffic (and detours) cost the delivering robots."""
        return self.robot_steps - self.shortest_steps

    def summary(self) -> str:
        return (
            f"{self.delivered}/{self.episodes * self.robots} packages delivered in "
            f"{self.robot_steps} robot-steps against {self.shortest_steps} on shortest paths "
            f"(delay {self.delay}); {self.refused} moves refused by traffic, "
            f"{self.deadlocks} episode(s) stuck at the time limit"
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "episodes": self.episodes,
            "robots": self.robots,
            "delivered": self.delivered,
            "robot_steps": self.robot_steps,
            "shortest_steps": self.shortest_steps,
            "delay": self.delay,
            "refused": self.refused,
            "deadlocks": self.deadlocks,
        }


def evaluate_fleet(
    env: WarehouseFleetEnv, policy: FleetPolicy, *, seeds: range = range(20)
) -> FleetEvaluation:
    """Play ``policy`` on ``env`` (which must not be lifelong) once per seed."""
    if env.lifelong:
        raise ValueError("evaluate a fleet without lifelong packages: each robot delivers one")
    delivered = robot_steps = shortest = refused = deadlocks = 0
    for seed in seeds:
        observations, infos = env.reset(seed=seed)
        optimal = {agent: info["optimal_steps"] for agent, info in infos.items()}
        step = 0
        while env.agents:
            live = {agent: observations[agent] for agent in env.agents}  # not the parked
            observations, _, terminations, truncations, infos = env.step(policy(env, live, infos))
            step += 1
            for agent, info in infos.items():
                refused += info["refused"]
                if terminations[agent]:
                    delivered += 1
                    robot_steps += step
                    shortest += optimal[agent]
            if any(truncations.values()):
                deadlocks += 1
    return FleetEvaluation(
        len(seeds), env.num_robots, delivered, robot_steps, shortest, refused, deadlocks
    )


def record_fleet_episode(
    env: WarehouseFleetEnv, policy: FleetPolicy, *, seed: int, max_steps: int
) -> tuple[Animation, int]:
    """Play ``policy`` from ``env.reset(seed=seed)`` for at most ``max_steps`` joint
    steps; the episode as an animation in real time (every physics step in the
    physics world, one frame a step in the grid twin) and the packages delivered.

    Raises:
        ValueError: if ``env`` does not render ``"rgb_array"`` frames.
    """
    if env.render_mode != "rgb_array":
        raise ValueError("record_fleet_episode needs render_mode='rgb_array'")
    observations, infos = env.reset(seed=seed)
    frames = [env.render()]
    delivered = 0
    for _ in range(max_steps):
        if not env.agents:
            break
        live = {agent: observations[agent] for agent in env.agents}
        observations, rewards, _, _, infos = env.step(policy(env, live, infos))
        delivered += int(sum(rewards.values()))
        if env.physics:
            frames.extend(env.move_frames()[:-1])  # the snapped frame follows
        frames.append(env.render())
    fps = 1 / env.config.dt if env.physics else env.metadata["render_fps"]
    return Animation(frames, fps), delivered


def fleet_table_metadata(
    env: WarehouseFleetEnv, config: QLearningConfig, env_id: str
) -> dict[str, Any]:
    """The metadata saved with a fleet's shared table (see
    :func:`~warehouse_phys.qlearning.save_q_table`): a single table's, with the
    number of robots; ``env_id`` is the single environment of the same floor and world."""
    from warehouse_phys import __version__

    layout = env.grid.layout
    return {
        "format": TABLE_FORMAT,
        "format_version": TABLE_FORMAT_VERSION,
        "env_id": env_id,
        "grid_rows": env.grid.rows,
        "grid_cols": env.grid.cols,
        "episodes": config.episodes,
        "alpha": config.alpha,
        "gamma": config.gamma,
        "seed": config.seed,
        "package_version": __version__,
        "layout": None if layout is None else list(layout),
        "layout_name": None if layout is None else preset_name(layout),
        "robots": env.num_robots,
    }


def sample_fleet_gaps(
    env: WarehouseFleetEnv, policy: FleetPolicy, steps: int, *, seed: int
) -> np.ndarray:
    """``info["min_gap"]`` of every robot over ``steps`` joint steps of ``policy`` [cells]:
    how close each robot's disc came to another's during each step.

    The fleet is reset with ``seed``, and again (unseeded) whenever an episode ends.

    Raises:
        ValueError: if ``env`` is not the physics world (the grid twin has no discs).
    """
    if not env.physics:
        raise ValueError("only the physics world (physics=True) has discs that can come close")
    observations, infos = env.reset(seed=seed)
    gaps = []
    for _ in range(steps):
        if not env.agents:
            observations, infos = env.reset()
        live = {agent: observations[agent] for agent in env.agents}
        observations, _, _, _, infos = env.step(policy(env, live, infos))
        gaps.extend(info["min_gap"] for info in infos.values())
    return np.array(gaps, dtype=np.float64)


def random_fleet_policy(seed: int) -> FleetPolicy:
    """Every robot takes a uniformly random action of the five, from a generator of ``seed``."""
    rng = np.random.default_rng([seed, 3])

    def policy(
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        return {agent: int(rng.integers(FLEET_ACTIONS)) for agent in observations}

    return policy
