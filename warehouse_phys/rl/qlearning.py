"""Tabular Q-learning for the warehouse environments: train, evaluate, save, load.

The Q-table has shape ``(R, C, R, C, 4)`` and is indexed by the observation
``[robot_row, robot_col, target_row, target_col]`` plus the action. Training is
the classic warehouse-robot tutorial's algorithm, made reproducible: an
epsilon-greedy policy whose random draws all come from one seeded
``numpy.random.Generator``, the update
``Q[s, a] += alpha * (r + gamma * max_a' Q[s', a'] - Q[s, a])`` without
bootstrapping from a terminal state, and an epsilon that starts at 1 and falls
linearly by ``1 / episodes`` after each episode, down to 0.

Everything here takes a Gymnasium environment made by the caller, so the same
functions serve the command line (``python -m warehouse_phys.train``), the
notebooks and any script::

    env = gym.make("warehouse-robot-phys-v0")
    result = train(env, QLearningConfig(episodes=1000, seed=0))
    print(evaluate(env, result.q).table())
    save_q_table("qtable.npz", result.q, table_metadata(env, result.config))

Tables are saved as ``.npz`` archives holding only numbers and a JSON string,
written atomically, and loaded without pickle and with strict checks, so loading a
file can never run code: that file format is :mod:`warehouse_phys.rl.qtable_file`, whose
names are importable from here too, as are those of the greedy policy and its evaluation
(:mod:`warehouse_phys.rl.greedy_policy`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

# The greedy policy and its evaluation live in greedy_policy; re-exported here, where
# they lived first and where the README, the notebooks and the tests import them.
from warehouse_phys.rl.greedy_policy import (
    Evaluation,
    TargetResult,
    evaluate,
    greedy_action,
    greedy_actions,
    grid_size,
    state_values,
)

# The table file and the memory budget live in qtable_file; re-exported here, where
# they lived first and where the README, the notebooks and the tests import them.
from warehouse_phys.rl.qtable_file import (
    MAX_TABLE_ROBOTS,
    METADATA_MAX_BYTES,
    RECORD_BYTES_PER_EPISODE,
    TABLE_FORMAT,
    TABLE_FORMAT_VERSION,
    TRAINING_MEMORY_BUDGET,
    QTableError,
    check_table,
    check_training_memory,
    load_q_table,
    make_table_metadata,
    save_q_table,
    table_actions,
    table_bytes,
    table_kind,
    table_tail,
)


@dataclass(frozen=True)
class QLearningConfig:
    """The hyper-parameters of a training run; the defaults are the tutorial's.

    Raises:
        TypeError: if a field has the wrong type.
        ValueError: if a value is out of range; the message names it.
    """

    #: Number of training episodes.
    episodes: int = 1000
    #: Learning rate, in (0, 1].
    alpha: float = 0.9
    #: Discount factor, in [0, 1].
    gamma: float = 0.9
    #: Seed of the first ``reset`` and of the agent's own random generator.
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("episodes", "seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise TypeError(f"{name} must be an integer, got {value!r}")
        for name in ("alpha", "gamma"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
                raise TypeError(f"{name} must be a number, got {value!r}")
        if self.episodes < 1:
            raise ValueError(f"episodes must be at least 1, got {self.episodes}")
        if self.seed < 0:
            raise ValueError(f"seed must be non-negative, got {self.seed}")
        if not 0 < self.alpha <= 1:
            raise ValueError(f"alpha must be in (0, 1], got {self.alpha}")
        if not 0 <= self.gamma <= 1:
            raise ValueError(f"gamma must be in [0, 1], got {self.gamma}")

    def epsilon(self, episode: int) -> float:
        """Exploration rate of the 0-based ``episode``: ``1 - episode / episodes``, at least 0
        (see :func:`exploration_rate`)."""
        return float(exploration_rate(episode, self.episodes))


def exploration_rate(episode: int | np.ndarray, episodes: int) -> np.ndarray:
    """The epsilon of the 0-based ``episode`` (a number or an array of them) in a run of
    ``episodes``: ``1 - episode / episodes``, at least 0. It starts at 1 and falls
    linearly by ``1 / episodes`` after each episode, the schedule of every learner here."""
    return np.maximum(1.0 - np.asarray(episode) / episodes, 0.0)


def epsilon_schedule(episodes: int) -> np.ndarray:
    """The exploration rate of each episode of a run of ``episodes``: a float64 array
    of :func:`exploration_rate` for ``0, 1, ..., episodes - 1``."""
    return exploration_rate(np.arange(episodes), episodes)


@dataclass(frozen=True)
class TrainingResult:
    """The learnt table and one entry per episode in each record array."""

    q: np.ndarray
    config: QLearningConfig
    #: Actions taken in each episode.
    steps: np.ndarray
    #: Sum of rewards of each episode.
    returns: np.ndarray
    #: Whether each episode ended on the target (``terminated``).
    reached_target: np.ndarray
    #: Whether each episode was cut by the time limit before reaching the target.
    truncated: np.ndarray
    #: The exploration rate each episode was played with.
    epsilon: np.ndarray


def new_q_table(rows: int, cols: int) -> np.ndarray:
    """An all-zero float64 Q-table for a ``rows`` x ``cols`` floor: shape ``(R, C, R, C, 4)``.

    Raises:
        ValueError: if the table alone would exceed :data:`TRAINING_MEMORY_BUDGET`.
    """
    check_training_memory(rows, cols, 0)
    return np.zeros((rows, cols, rows, cols, 4), dtype=np.float64)


def agent_rng(seed: int) -> np.random.Generator:
    """The agent's random generator for ``seed``.

    Its stream differs from the one ``env.reset(seed=seed)`` gives the
    environment, so exploration and target placement are not correlated.
    """
    return np.random.default_rng([seed, 1])


def train(
    env: gym.Env,
    config: QLearningConfig | None = None,
    *,
    q: np.ndarray | None = None,
    on_episode: Callable[[int], None] | None = None,
) -> TrainingResult:
    """Train a Q-table on ``env`` with epsilon-greedy Q-learning.

    The first episode starts with ``env.reset(seed=config.seed)``, later ones
    with ``env.reset()``; an episode ends when the environment terminates or
    truncates it (``gym.make`` adds the time limit). Training starts from an
    all-zero table, or from a copy of ``q`` to carry on from a saved one.
    ``on_episode(i)``, if given, is called after episode ``i`` (to drive a
    progress bar, say).

    Raises:
        ValueError: if ``env`` is not a warehouse environment with a 4-integer
            observation and 4 actions, ``q`` does not fit its grid, or the
            table and the per-episode records would exceed
            :data:`TRAINING_MEMORY_BUDGET` (checked before anything is allocated).
    """
    config = config or QLearningConfig()
    rows, cols = grid_size(env)
    check_training_memory(rows, cols, config.episodes)
    if q is None:
        q = new_q_table(rows, cols)
    else:
        q = np.array(q, dtype=np.float64)
        check_table(q, rows, cols, where="initial table")
    rng = agent_rng(config.seed)
    alpha, gamma = config.alpha, config.gamma

    def play(seed: int | None, epsilon: float) -> EpisodeOutcome:
        obs, _ = env.reset(seed=seed)
        state = tuple(obs.tolist())
        n_steps, total = 0, 0.0
        while True:
            values = q[state]
            action = epsilon_greedy(values, epsilon, rng)
            obs, reward, terminated, truncated, _ = env.step(action)
            next_state = tuple(obs.tolist())
            td_update(values, action, reward, None if terminated else q[next_state], alpha, gamma)
            n_steps += 1
            total += reward
            if terminated or truncated:
                return n_steps, total, terminated, truncated and not terminated
            state = next_state

    return run_episodes(config, q, play, on_episode)


# ----------------------------------------------- what every tabular learner shares
#: One training episode's records: its steps, its return, whether it reached its end
#: (the target, or every package delivered) and whether a time limit cut it first.
EpisodeOutcome = tuple[int, float, bool, bool]


def run_episodes(
    config: QLearningConfig,
    q: np.ndarray,
    play_episode: Callable[[int | None, float], EpisodeOutcome],
    on_episode: Callable[[int], None] | None = None,
) -> TrainingResult:
    """Play the ``config.episodes`` episodes of a training run and keep their records.

    Episode ``i`` is ``play_episode(seed, epsilon)``, which resets the environment with
    ``seed`` (``config.seed`` for the first episode, ``None`` after it: unseeded),
    plays it with the exploration rate ``epsilon`` of :func:`epsilon_schedule`, updates
    ``q`` in place and returns its :data:`EpisodeOutcome`. ``on_episode(i)``, if given,
    is called after episode ``i``. Returns the table (``q`` itself) and the records.
    """
    episodes = config.episodes
    steps = np.zeros(episodes, dtype=np.int64)
    returns = np.zeros(episodes, dtype=np.float64)
    reached = np.zeros(episodes, dtype=bool)
    truncated = np.zeros(episodes, dtype=bool)
    epsilons = epsilon_schedule(episodes)
    for episode in range(episodes):
        seed = config.seed if episode == 0 else None
        outcome = play_episode(seed, epsilons[episode])
        steps[episode], returns[episode], reached[episode], truncated[episode] = outcome
        if on_episode is not None:
            on_episode(episode)
    return TrainingResult(
        q=q,
        config=config,
        steps=steps,
        returns=returns,
        reached_target=reached,
        truncated=truncated,
        epsilon=epsilons,
    )


def epsilon_greedy(
    values: np.ndarray, epsilon: float, rng: np.random.Generator, *, random_ties: bool = False
) -> int:
    """The epsilon-greedy action over one state's action ``values``, drawn from ``rng``.

    By default (the single robot's learner, the tutorial's rule) one uniform draw is
    made every time: below ``epsilon``, a uniformly random action follows; otherwise
    the first of the best-valued actions. With ``random_ties`` (a fleet's robots, so
    that robots in the same situation do not all pick the first action) no draw decides
    at ``epsilon`` 0 or 1, and ties among the best are broken by a draw.
    """
    n_actions = values.shape[-1]
    if not random_ties:
        if rng.random() < epsilon:
            return int(rng.integers(n_actions))
        return int(values.argmax())
    if epsilon > 0.0 and (epsilon >= 1.0 or rng.random() < epsilon):
        return int(rng.integers(n_actions))
    best = np.flatnonzero(values == values.max())
    return int(best[rng.integers(len(best))] if len(best) > 1 else best[0])


def td_update(
    values: np.ndarray,
    action: int,
    reward: float,
    next_values: np.ndarray | None,
    alpha: float,
    gamma: float,
) -> None:
    """The Q-learning update of one step, in place on the state's action ``values``:
    ``Q[s, a] += alpha * (r + gamma * max_a' Q[s', a'] - Q[s, a])``, where
    ``next_values`` are those of ``s'``, or ``None`` when ``s'`` is terminal (no
    bootstrapping from it)."""
    if next_values is None:
        td_target = reward
    else:
        td_target = reward + gamma * next_values[next_values.argmax()]
    values[action] += alpha * (td_target - values[action])


# ------------------------------------------------------------------ metadata
def table_metadata(env: gym.Env, config: QLearningConfig) -> dict[str, Any]:
    """The metadata saved next to a table trained on ``env`` with ``config`` (see
    :func:`~warehouse_phys.rl.qtable_file.make_table_metadata`)."""
    grid_size(env)  # a warehouse environment
    spec = getattr(env, "spec", None)
    env_id = spec.id if spec else type(env.unwrapped).__name__
    return make_table_metadata(env_id, env.unwrapped.grid, config)


__all__ = [
    "MAX_TABLE_ROBOTS",
    "METADATA_MAX_BYTES",
    "RECORD_BYTES_PER_EPISODE",
    "TABLE_FORMAT",
    "TABLE_FORMAT_VERSION",
    "TRAINING_MEMORY_BUDGET",
    "EpisodeOutcome",
    "Evaluation",
    "QLearningConfig",
    "QTableError",
    "TargetResult",
    "TrainingResult",
    "agent_rng",
    "check_table",
    "check_training_memory",
    "epsilon_greedy",
    "epsilon_schedule",
    "evaluate",
    "exploration_rate",
    "greedy_action",
    "greedy_actions",
    "load_q_table",
    "make_table_metadata",
    "new_q_table",
    "run_episodes",
    "save_q_table",
    "state_values",
    "table_actions",
    "table_bytes",
    "table_kind",
    "table_metadata",
    "table_tail",
    "td_update",
    "train",
]
