"""Wall time of 1000 training episodes with the default trainer, next to the tutorial's loop.

The reference is the classic warehouse-robot tutorial's plain Q-learning loop
(global-free, but otherwise as written there) on the grid twin; the package's
trainer runs on the grid twin and on the physics-backed environment. Each
figure is the median of several runs, reported with its ratio to the reference.

    python benchmarks/training.py [--episodes N] [--repeats K]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import warehouse_phys
from warehouse_phys.qlearning import QLearningConfig, train


def tutorial_loop(episodes: int, seed: int = 0) -> np.ndarray:
    """The tutorial's training loop, on the grid twin: the reference."""
    env = gym.make(warehouse_phys.GRID_ENV_ID)
    rng = np.random.default_rng(seed)
    q = np.zeros((4, 5, 4, 5, 4))
    alpha, gamma, epsilon = 0.9, 0.9, 1.0
    state, _ = env.reset(seed=seed)
    for _ in range(episodes):
        terminated = truncated = False
        while not (terminated or truncated):
            if rng.random() < epsilon:
                action = int(rng.integers(4))
            else:
                action = int(np.argmax(q[tuple(state)]))
            new_state, reward, terminated, truncated, _ = env.step(action)
            target = reward if terminated else reward + gamma * np.max(q[tuple(new_state)])
            q[(*state, action)] += alpha * (target - q[(*state, action)])
            state = new_state
        epsilon = max(epsilon - 1 / episodes, 0)
        state, _ = env.reset()
    return q


def seconds(run: Callable[[], object], repeats: int) -> float:
    """The median wall time of ``repeats`` calls of ``run``."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000, help="episodes per run")
    parser.add_argument("--repeats", type=int, default=5, help="runs per figure (median)")
    args = parser.parse_args(argv)
    if args.episodes < 1 or args.repeats < 1:
        parser.error("--episodes and --repeats must be at least 1")

    config = QLearningConfig(episodes=args.episodes)
    figures = {
        "tutorial loop, grid twin (reference)": seconds(
            lambda: tutorial_loop(args.episodes), args.repeats
        ),
        f"trainer, {warehouse_phys.GRID_ENV_ID}": seconds(
            lambda: train(gym.make(warehouse_phys.GRID_ENV_ID), config), args.repeats
        ),
        f"trainer, {warehouse_phys.PHYSICS_ENV_ID}": seconds(
            lambda: train(gym.make(warehouse_phys.PHYSICS_ENV_ID), config), args.repeats
        ),
    }
    reference = next(iter(figures.values()))
    print(
        f"{'training ' + str(args.episodes) + ' episodes':<45} {'seconds':>9} {'vs reference':>13}"
    )
    for name, value in figures.items():
        print(f"{name:<45} {value:>9.3f} {value / reference:>12.2f}x")
    print(f"(median of {args.repeats} runs)")
    return figures


if __name__ == "__main__":
    main()
