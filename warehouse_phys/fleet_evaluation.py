"""How well a fleet's policy delivers, and the baseline policies it is compared with.

:func:`evaluate_fleet` plays a policy over fixed seeds and reports what traffic
costs: packages delivered, the robots' steps against the sum of their shortest
paths, refused moves and deadlocks. :func:`shortest_path_policy` is the
baseline: each robot takes a move along a shortest path to its package and waits
when that cell is taken; :func:`random_fleet_policy` acts at random.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from warehouse_phys.animation import Animation
from warehouse_phys.fleet import WarehouseFleetEnv
from warehouse_phys.traffic import FLEET_ACTIONS, WAIT

#: A fleet policy: the environment, every live robot's observation and last info -> actions.
FleetPolicy = Callable[
    [WarehouseFleetEnv, dict[str, np.ndarray], dict[str, dict[str, Any]]], dict[str, int]
]


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
