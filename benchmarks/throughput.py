"""Actions per second of the warehouse environments next to Gymnasium's FrozenLake-v1.

Every environment runs the same pre-drawn random actions (resetting when an
episode ends), through ``gym.make`` as users call it and unwrapped. Each figure
is the median of several repeats, and is reported as a ratio to FrozenLake-v1
through ``gym.make`` measured in the same run, so that figures from different
machines compare. Headless: no render mode.

    python benchmarks/throughput.py [--actions N] [--repeats K]
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import numpy as np

import warehouse_phys

REFERENCE_ID = "FrozenLake-v1"
ENV_IDS = (REFERENCE_ID, warehouse_phys.GRID_ENV_ID, warehouse_phys.PHYSICS_ENV_ID)


def actions_per_second(env: gym.Env, actions: list[int]) -> float:
    """Run ``actions`` in ``env``, resetting after every episode end; actions per second."""
    env.reset(seed=0)
    step, reset = env.step, env.reset
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = step(action)
        if terminated or truncated:
            reset()
    return len(actions) / (time.perf_counter() - start)


def median_rate(env_id: str, actions: list[int], repeats: int, *, unwrapped: bool) -> float:
    """The median of ``repeats`` runs, each in a fresh environment made from ``env_id``."""
    rates = []
    for _ in range(repeats):
        env = gym.make(env_id)
        rates.append(actions_per_second(env.unwrapped if unwrapped else env, actions))
    return statistics.median(rates)


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--actions", type=int, default=100_000, help="actions per run")
    parser.add_argument("--repeats", type=int, default=5, help="runs per figure (median)")
    args = parser.parse_args(argv)
    if args.actions < 1 or args.repeats < 1:
        parser.error("--actions and --repeats must be at least 1")

    actions = np.random.default_rng(0).integers(4, size=args.actions).tolist()
    rates: dict[str, float] = {}
    for env_id in ENV_IDS:
        for unwrapped in (False, True):
            name = f"{env_id} ({'unwrapped' if unwrapped else 'gym.make'})"
            rates[name] = median_rate(env_id, actions, args.repeats, unwrapped=unwrapped)

    reference = rates[f"{REFERENCE_ID} (gym.make)"]
    print(f"{'environment':<45} {'actions/s':>12} {'vs ' + REFERENCE_ID:>16}")
    for name, rate in rates.items():
        print(f"{name:<45} {rate:>12,.0f} {rate / reference:>15.2f}x")
    print(f"(median of {args.repeats} runs of {args.actions:,} random actions each)")
    return rates


if __name__ == "__main__":
    main()
