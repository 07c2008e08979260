"""Tabular Q-learning for a fleet.

Every robot of a :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv` is an
independent Q-learner, and all of them share one table over the local
observation ``[row, col, package_row, package_col]``: shape ``(R, C, R, C, 5)``,
the four moves and WAIT; or, with ``observation="neighbours"``, over the same
four numbers and the mask of adjacent robots: ``(R, C, R, C, 16, 5)``, so that a
robot can learn to step aside. The learned policy (:func:`greedy_fleet_policy`)
follows the table and sends a robot that stops making progress on random walks of
growing length, which is what untangles robots that a table alone leaves in a
standoff. How well a policy delivers, and the baseline policies, live in
:mod:`warehouse_phys.rl.fleet_evaluation`, recording a fleet's episode in
:mod:`warehouse_phys.viz.recording` (both re-exported here).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.rl.fleet_evaluation import (  # re-exported: they lived here first
    FleetEvaluation,
    FleetPolicy,
    evaluate_fleet,
    random_fleet_policy,
    shortest_path_policy,
)
from warehouse_phys.rl.qlearning import (
    EpisodeOutcome,
    QLearningConfig,
    TrainingResult,
    agent_rng,
    check_training_memory,
    epsilon_greedy,
    make_table_metadata,
    run_episodes,
    td_update,
)
from warehouse_phys.world.traffic import FLEET_ACTIONS

#: Masks of a neighbours observation: four bits, one per adjacent cell.
NEIGHBOUR_MASKS = 16


#: Fleet observations a shared table can be indexed by.
TABLE_OBSERVATIONS = ("local", "neighbours")
#: How often the learned fleet policy acts at random by default (see
#: :func:`greedy_fleet_policy`).
FLEET_EVAL_EPSILON = 0.05
#: Joint steps a training episode lasts at most on floors up to 25 cells across (the
#: default floor's time limit; see :func:`training_steps`).
FLEET_TRAINING_STEPS = 200
#: Steps a robot of the learned fleet policy goes without progress before it walks at
#: random, and its first random walk's longest length (see :func:`greedy_fleet_policy`).
FLEET_PATIENCE = 4
#: The longest random walk of a stuck robot of the learned fleet policy [steps].
BACKOFF_WINDOW_CAP = 1024


def new_fleet_q_table(rows: int, cols: int, observation: str = "local") -> np.ndarray:
    """An all-zero float64 table for a fleet on a ``rows`` x ``cols`` floor:
    ``(R, C, R, C, 5)`` for ``"local"`` observations, ``(R, C, R, C, 16, 5)`` for
    ``"neighbours"``."""
    if observation not in TABLE_OBSERVATIONS:
        raise ValueError(
            f"a shared table reads {' or '.join(TABLE_OBSERVATIONS)} observations, "
            f"got {observation!r}"
        )
    masks = (NEIGHBOUR_MASKS,) if observation == "neighbours" else ()
    check_training_memory(rows, cols, 0, tail=(*masks, FLEET_ACTIONS))
    return np.zeros((rows, cols, rows, cols, *masks, FLEET_ACTIONS), dtype=np.float64)


def training_steps(rows: int, cols: int) -> int:
    """The joint steps a training episode of :func:`train_fleet` lasts at most on a
    ``rows`` x ``cols`` floor: :data:`FLEET_TRAINING_STEPS`, or four crossings of a
    larger floor (``4 * (rows + cols)``)."""
    return max(FLEET_TRAINING_STEPS, 4 * (rows + cols))


def train_fleet(
    env: WarehouseFleetEnv,
    config: QLearningConfig | None = None,
    *,
    on_episode: Callable[[int], None] | None = None,
    max_steps: int | None = None,
) -> TrainingResult:
    """Train one shared table with every robot an epsilon-greedy Q-learner.

    The first episode starts with ``env.reset(seed=config.seed)``, later ones
    with ``env.reset()``; exploration draws from
    :func:`~warehouse_phys.rl.qlearning.agent_rng` of the seed, one draw per robot
    in robot order, so a run is reproducible. After each joint step every robot
    that acted updates the table with its own reward and next observation.

    The result's records, per episode, are a fleet's: ``steps`` its joint steps,
    ``returns`` the packages delivered, ``reached_target`` whether every robot
    delivered and ``truncated`` whether the time limit came first.

    Ties between equal values are broken at random (from the same generator), so
    robots in the same situation do not all pick the first action.

    A training episode ends at the fleet's time limit or after ``max_steps`` joint
    steps, whichever comes first (the next one starts with a reset; the table
    bootstraps from the last observations as at any truncation). By default
    ``max_steps`` is :func:`training_steps` of the floor: the early episodes, played
    almost at random, would otherwise run to a long time limit (1200 steps on
    ``aisles``) and take most of the training time while teaching little.

    Raises:
        ValueError: if ``env`` gives global observations (the table needs the local
            or the neighbours ones), or ``max_steps`` is below 1.
    """
    if env.observation not in TABLE_OBSERVATIONS:
        raise ValueError("a shared table needs observation='local' or 'neighbours'")
    config = config or QLearningConfig()
    rows, cols = env.grid.rows, env.grid.cols
    masks = (NEIGHBOUR_MASKS,) if env.observation == "neighbours" else ()
    check_training_memory(rows, cols, config.episodes, tail=(*masks, FLEET_ACTIONS))
    q = new_fleet_q_table(rows, cols, env.observation)
    if max_steps is None:
        max_steps = training_steps(rows, cols)
    elif max_steps < 1:
        raise ValueError(f"max_steps must be at least 1, got {max_steps!r}")
    rng = agent_rng(config.seed)
    alpha, gamma = config.alpha, config.gamma

    def play(seed: int | None, epsilon: float) -> EpisodeOutcome:
        observations, _ = env.reset(seed=seed)
        n_steps, total, cut = 0, 0.0, False
        while env.agents:
            if n_steps >= max_steps:
                cut = True
                break
            states = {agent: tuple(obs.tolist()) for agent, obs in observations.items()}
            actions = {
                agent: epsilon_greedy(q[states[agent]], epsilon, rng, random_ties=True)
                for agent in env.agents
            }
            observations, rewards, terminations, truncations, _ = env.step(actions)
            for agent, action in actions.items():
                next_values = (
                    None if terminations[agent] else q[tuple(observations[agent].tolist())]
                )
                td_update(q[states[agent]], action, rewards[agent], next_values, alpha, gamma)
            n_steps += 1
            total += sum(rewards.values())
            cut = cut or any(truncations.values())
        return n_steps, total, not cut, cut

    return run_episodes(config, q, play, on_episode)


def greedy_fleet_policy(
    q: np.ndarray,
    *,
    epsilon: float = FLEET_EVAL_EPSILON,
    patience: int | None = FLEET_PATIENCE,
    seed: int = 0,
) -> FleetPolicy:
    """The learned fleet policy: every robot takes the shared table's best action for its
    own observation (ties broken at random), with probability ``epsilon`` a uniformly
    random action, and uniformly random actions for a while when it is stuck.

    A robot is *stuck* once it has gone ``patience`` steps without making progress.
    Its progress is the table's own measure of how near it is to its package, the best
    value of its cell with nobody beside it (:func:`cell_values`): it made progress on
    a step that raised this above every value it had before for the same package.
    A stuck robot walks at random for 1 to ``w`` steps, drawn uniformly, then follows
    the table again; ``w`` starts at ``patience`` and doubles each time the robot is
    stuck again without progress in between (binary exponential backoff, as Ethernet
    resolves collisions; at most :data:`BACKOFF_WINDOW_CAP`), and progress resets it.

    This is what breaks standoffs. A greedy table policy is deterministic up to its
    ties: robots in the same joint situation ask for the same refused moves for ever,
    two robots meeting head-on both wait or both back off and come back, and a robot
    whose way is walled by a parked robot it no longer sees turns round, sees it again
    and turns back (the neighbours observation shows only the adjacent cells). Short
    random walks of different lengths untangle the first two; longer and longer ones
    take a robot round the third, while robots that make progress follow the table.
    ``patience=None`` leaves that out, and with ``epsilon=0`` too this is the plain
    greedy policy.

    Draws come from a generator of ``seed``, started afresh at every reset, so an
    evaluation is reproducible.

    Raises:
        ValueError: if ``epsilon`` is not in [0, 1] or ``patience`` is below 1.
    """
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon!r}")
    if patience is not None and patience < 1:
        raise ValueError(f"patience must be at least 1 step (or None), got {patience!r}")
    state: dict[str, Any] = {"rng": None}

    def policy(
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        if state["rng"] is None or env.steps == 0:
            state["rng"] = np.random.default_rng([seed, 7])
            state["progress"] = _Progress(patience)
        rng, progress = state["rng"], state["progress"]
        actions = {}
        for agent, obs in observations.items():
            key = tuple(obs.tolist())
            stuck = progress.stuck(agent, q, key, rng)
            actions[agent] = epsilon_greedy(
                q[key], 1.0 if stuck else epsilon, rng, random_ties=True
            )
        return actions

    return policy


def cell_values(q: np.ndarray, observation: tuple[int, ...]) -> np.ndarray:
    """The action values of a robot's cell and package with nobody beside it: the
    table's row for the first four numbers of ``observation`` (and, in a neighbours
    table, the empty mask)."""
    values = q[observation[:4]]
    return values[0] if values.ndim > 1 else values


@dataclass(slots=True)
class _Robot:
    """What :class:`_Progress` remembers of one robot."""

    package: tuple[int, ...]
    #: The best cell value it reached for this package.
    best: float
    #: Steps since then, outside random walks.
    idle: int = 0
    #: Random steps left of its walk.
    walk: int = 0
    #: Its next walk's longest length.
    window: int = 1


class _Progress:
    """Which robots are stuck, and for how long they walk at random (see
    :func:`greedy_fleet_policy`); ``patience=None``: never stuck."""

    def __init__(self, patience: int | None) -> None:
        self.patience = patience
        self.robots: dict[str, _Robot] = {}

    def stuck(
        self, agent: str, q: np.ndarray, observation: tuple[int, ...], rng: np.random.Generator
    ) -> bool:
        """Record the robot's ``observation`` of this step; whether it walks at random now."""
        if self.patience is None:
            return False
        value = float(cell_values(q, observation).max())
        robot = self.robots.get(agent)
        if robot is None or value > robot.best or robot.package != observation[2:4]:
            self.robots[agent] = _Robot(observation[2:4], value, window=self.patience)
            return False
        if robot.walk > 0:
            robot.walk -= 1
            return True
        robot.idle += 1
        if robot.idle < self.patience:
            return False
        robot.idle, robot.walk = 0, int(rng.integers(robot.window))  # this step and 0..w-1 more
        robot.window = min(2 * robot.window, BACKOFF_WINDOW_CAP)
        return True


def fleet_table_metadata(
    env: WarehouseFleetEnv, config: QLearningConfig, env_id: str
) -> dict[str, Any]:
    """The metadata saved with a fleet's shared table (see
    :func:`~warehouse_phys.rl.qlearning.save_q_table`): a single table's, with the
    number of robots and their observation; ``env_id`` is the single environment of the
    same floor and world."""
    return make_table_metadata(
        env_id, env.grid, config, robots=env.num_robots, observation=env.observation
    )


__all__ = [
    "FleetEvaluation",
    "FleetPolicy",
    "cell_values",
    "evaluate_fleet",
    "fleet_table_metadata",
    "greedy_fleet_policy",
    "new_fleet_q_table",
    "random_fleet_policy",
    "shortest_path_policy",
    "train_fleet",
    "training_steps",
]


#: Names that moved to :mod:`warehouse_phys.viz.recording` (a floor above this one),
#: still found here for code written before they moved.
_MOVED_UP = ("record_fleet_episode", "sample_fleet_gaps")


def __getattr__(name: str) -> Any:
    if name in _MOVED_UP:
        from warehouse_phys.viz import recording  # on demand: viz sits above rl

        return getattr(recording, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
