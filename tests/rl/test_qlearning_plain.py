"""Tabular Q-learning written the plain way, as in the warehouse-robot tutorial, learns the task."""

import gymnasium as gym
import numpy as np
import pytest

import warehouse_phys  # noqa: F401 - registers the environment ids


def train_plain_q(episodes, seed, rows=4, cols=5):
    env = gym.make("warehouse-robot-v0", grid_rows=rows, grid_cols=cols)
    rng = np.random.default_rng(seed)
    q = np.zeros(
        (
            env.unwrapped.grid_rows,
            env.unwrapped.grid_cols,
            env.unwrapped.grid_rows,
            env.unwrapped.grid_cols,
            env.action_space.n,
        )
    )
    alpha, gamma, epsilon = 0.9, 0.9, 1.0
    state, _ = env.reset(seed=seed)
    for _ in range(episodes):
        terminated = truncated = False
        while not (terminated or truncated):
            if rng.random() < epsilon:
                action = int(rng.integers(env.action_space.n))
            else:
                action = int(np.argmax(q[tuple(state)]))
            new_state, reward, terminated, truncated, _ = env.step(action)
            target = reward if terminated else reward + gamma * np.max(q[tuple(new_state)])
            q[(*state, action)] += alpha * (target - q[(*state, action)])
            state = new_state
        epsilon = max(epsilon - 1 / episodes, 0)
        state, _ = env.reset()
    env.close()
    return q


def greedy_steps(q, target, rows=4, cols=5):
    """Steps the greedy policy takes from the start to ``target``, or None if it never arrives."""
    env = gym.make("warehouse-robot-v0", grid_rows=rows, grid_cols=cols)
    state, info = env.reset(options={"target": target})
    optimal = info["optimal_steps"]
    for step in range(1, env.spec.max_episode_steps + 1):
        state, _, terminated, truncated, _ = env.step(int(np.argmax(q[tuple(state)])))
        if terminated:
            return step, optimal
        if truncated:
            break
    return None, optimal


@pytest.mark.parametrize("seed", [0, 1])
def test_plain_q_learning_reaches_every_target_by_a_shortest_path(seed):
    q = train_plain_q(episodes=1000, seed=seed)
    targets = [(r, c) for r in range(1, 4) for c in range(1, 5)]
    results = {target: greedy_steps(q, target) for target in targets}
    assert all(steps is not None for steps, _ in results.values()), results
    assert all(steps == optimal for steps, optimal in results.values()), results


def test_untrained_table_does_not_reach_the_targets():
    """The evaluation above can fail: an all-zero table keeps pressing LEFT at the start."""
    q = np.zeros((4, 5, 4, 5, 4))
    assert greedy_steps(q, (1, 1)) == (None, 2)


def test_tutorial_style_script_runs_unchanged():
    """The tutorial's loop: global `random`, sampled and argmax actions, no truncation check."""
    import random

    random.seed(0)
    env = gym.make("warehouse-robot-v0", render_mode=None)
    env.action_space.seed(0)
    q = np.zeros(
        (
            env.unwrapped.grid_rows,
            env.unwrapped.grid_cols,
            env.unwrapped.grid_rows,
            env.unwrapped.grid_cols,
            env.action_space.n,
        )
    )
    learning_rate_a, discount_factor_g, epsilon, episodes = 0.9, 0.9, 1, 300
    steps_per_episode = np.zeros(episodes)
    for i in range(episodes):
        state = env.reset(seed=i)[0]
        terminated = False
        step_count = 0
        while not terminated:
            if random.random() < epsilon:
                action = env.action_space.sample()
            else:
                action = np.argmax(q[tuple(state)])
            new_state, reward, terminated, _, _ = env.step(action)
            q[(*tuple(state), action)] = q[(*tuple(state), action)] + learning_rate_a * (
                reward
                + discount_factor_g * np.max(q[tuple(new_state)])
                - q[(*tuple(state), action)]
            )
            state = new_state
            step_count += 1
        steps_per_episode[i] = step_count
        epsilon = max(epsilon - 1 / episodes, 0)
    env.close()
    # Greedy episodes at the end walk straight to the target.
    last = steps_per_episode[-50:]
    assert last.mean() < 6, last
    assert np.count_nonzero(q) > 0
