"""Recording episodes: every step, every frame and, in the physics-backed environment, the motion.

:func:`record_episode` plays a policy in an environment made with
``render_mode="rgb_array"`` and keeps what happened: observations, actions,
rewards, a frame after each step and the frames *between* steps. In the grid
twin the robot jumps from cell to cell, so the motion is one frame per step
at 4 frames per second; in the physics-backed environment it is one frame per
physics step (60 per second), the body driving from cell to cell. Either way
:meth:`EpisodeRecording.animation` plays the episode in real time.

:func:`sample_snap_errors` collects the physics-backed environment's
pre-snap errors over many random moves.

A fleet's episodes are recorded the same way: :func:`record_fleet_episode` plays a
fleet policy and keeps its frames as an animation in real time, and
:func:`sample_fleet_gaps` collects how close the physics fleet's robots came to each
other.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from warehouse_phys.drawing.animation import Animation
from warehouse_phys.envs import WarehousePhysicsEnv

if TYPE_CHECKING:  # annotations only: recording a single robot needs no fleet
    from warehouse_phys.envs.fleet import WarehouseFleetEnv
    from warehouse_phys.rl.fleet_evaluation import FleetPolicy

#: A policy maps an observation to an action.
Policy = Callable[[np.ndarray], int]


@dataclass(frozen=True, eq=False)
class EpisodeRecording:
    """One recorded episode; ``n`` is the number of steps taken."""

    #: ``(n + 1, 4)`` int64 observations: after the reset, then after each step.
    observations: np.ndarray
    #: ``(n,)`` int64 actions.
    actions: np.ndarray
    #: ``(n,)`` float64 rewards.
    rewards: np.ndarray
    #: ``(n,)`` float64 ``info["snap_error"]`` of each step [cells]; zeros in the grid twin.
    snap_errors: np.ndarray
    #: Whether the last step reached the target, or hit the time limit.
    terminated: bool
    truncated: bool
    #: ``n + 1`` frames: after the reset, then after each step.
    frames: tuple[np.ndarray, ...]
    #: The frames of the robot's motion at :attr:`fps`: the reset frame, then
    #: for each step the frames during the move, the last one after it.
    motion_frames: tuple[np.ndarray, ...]
    #: The rate that plays :attr:`motion_frames` in real time [frames/s].
    fps: float
    #: One ``(k, 2)`` float64 array per step of the robot's ``(row, col)`` in
    #: cell units during that move: the body after each physics step, before the
    #: snap (``k`` = steps per move), or in the grid twin the cell it jumped to.
    move_paths: tuple[np.ndarray, ...]

    @property
    def steps(self) -> int:
        """The number of steps taken."""
        return len(self.actions)

    @property
    def cells(self) -> np.ndarray:
        """``(n + 1, 2)`` int64: the robot's cell after the reset and after each step."""
        return self.observations[:, :2].copy()

    @property
    def target(self) -> tuple[int, int]:
        """The target's cell."""
        return int(self.observations[0, 2]), int(self.observations[0, 3])

    @property
    def path(self) -> np.ndarray:
        """The robot's whole path in cell units: the start cell, then every point of
        :attr:`move_paths`; continuous in the physics-backed environment."""
        start = self.observations[:1, :2].astype(np.float64)
        return np.concatenate([start, *self.move_paths])

    def animation(self, hold_start: float = 0.5, hold_end: float = 1.0) -> Animation:
        """The motion frames as an :class:`~warehouse_phys.drawing.animation.Animation`, in real
        time."""
        return Animation(self.motion_frames, self.fps, hold_start=hold_start, hold_end=hold_end)


def record_episode(
    env: gym.Env,
    policy: Policy,
    *,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    max_steps: int | None = None,
) -> EpisodeRecording:
    """Reset ``env`` with ``seed`` and ``options``, play ``policy`` and record everything.

    The episode ends on the target, at the environment's time limit, or after
    ``max_steps`` steps, whichever comes first.

    Raises:
        ValueError: if ``env`` does not render ``"rgb_array"`` frames, or
            ``max_steps`` is negative.
    """
    if env.render_mode != "rgb_array":
        raise ValueError(
            f"record_episode needs an environment made with render_mode='rgb_array', "
            f"not {env.render_mode!r}"
        )
    if max_steps is not None and max_steps < 0:
        raise ValueError(f"max_steps must be at least 0, got {max_steps}")
    physics = env.unwrapped if isinstance(env.unwrapped, WarehousePhysicsEnv) else None

    obs, _ = env.reset(seed=seed, options=options)
    frame = env.render()
    observations, actions, rewards, snap_errors = [obs], [], [], []
    frames, motion, move_paths = [frame], [frame], []
    terminated = truncated = False
    while not (terminated or truncated) and (max_steps is None or len(actions) < max_steps):
        action = int(policy(obs))
        obs, reward, terminated, truncated, info = env.step(action)
        frame = env.render()
        observations.append(obs)
        actions.append(action)
        rewards.append(float(reward))
        snap_errors.append(float(info.get("snap_error", 0.0)))
        frames.append(frame)
        if physics is not None:
            # The frames during the move; its last, before the snap, gives way to the snapped one.
            motion.extend(physics.move_frames()[:-1])
            move_paths.append(physics.last_move_path)
        else:
            move_paths.append(obs[None, :2].astype(np.float64))
        motion.append(frame)

    return EpisodeRecording(
        observations=np.array(observations, dtype=np.int64).reshape(-1, 4),
        actions=np.array(actions, dtype=np.int64),
        rewards=np.array(rewards, dtype=np.float64),
        snap_errors=np.array(snap_errors, dtype=np.float64),
        terminated=bool(terminated),
        truncated=bool(truncated),
        frames=tuple(frames),
        motion_frames=tuple(motion),
        fps=float(env.metadata["render_fps"]),
        move_paths=tuple(move_paths),
    )


def sample_snap_errors(env: gym.Env, moves: int, *, seed: int) -> np.ndarray:
    """``info["snap_error"]`` of ``moves`` uniformly random moves [cells].

    The environment is reset with ``seed`` and again (unseeded, so the sequence
    stays reproducible) whenever an episode ends; the actions come from a
    generator seeded with ``seed`` too.

    Raises:
        ValueError: if ``moves`` is negative or ``env`` reports no ``"snap_error"``
            (it is not the physics-backed environment).
    """
    if moves < 0:
        raise ValueError(f"moves must be at least 0, got {moves}")
    rng = np.random.default_rng([seed, 2])  # a stream of its own, apart from the env's
    actions = rng.integers(env.action_space.n, size=moves)
    errors = np.empty(moves, dtype=np.float64)
    _, info = env.reset(seed=seed)
    if "snap_error" not in info:
        raise ValueError(
            f"{env.spec.id if env.spec else type(env.unwrapped).__name__} reports no "
            "snap_error; use the physics-backed environment"
        )
    for i, action in enumerate(actions):
        _, _, terminated, truncated, info = env.step(int(action))
        errors[i] = info["snap_error"]
        if terminated or truncated:
            env.reset()
    return errors


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
    fps = 1 / env.physics.dt if env.physics else env.metadata["render_fps"]
    return Animation(frames, fps), delivered


def sample_fleet_gaps(
    env: WarehouseFleetEnv, policy: FleetPolicy, steps: int, *, seed: int
) -> np.ndarray:
    """``info["min_gap"]`` of every robot over ``steps`` joint steps of ``policy`` [cells]:
    how close each robot's disc came to another's during each step (``inf`` where no
    robot was within reach, see
    :meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.closest_approach`).

    The fleet is reset with ``seed``, and again (unseeded) whenever an episode ends.

    Raises:
        ValueError: if ``env`` is not the physics world (the grid twin has no discs), or
            does not track gaps (``track_gaps=False``).
    """
    if not env.physics:
        raise ValueError("only the physics world (physics=True) has discs that can come close")
    if not env.track_gaps:
        raise ValueError("this fleet does not measure min_gap: make it with track_gaps=True")
    observations, infos = env.reset(seed=seed)
    gaps = []
    for _ in range(steps):
        if not env.agents:
            observations, infos = env.reset()
        live = {agent: observations[agent] for agent in env.agents}
        observations, _, _, _, infos = env.step(policy(env, live, infos))
        gaps.extend(info["min_gap"] for info in infos.values())
    return np.array(gaps, dtype=np.float64)
