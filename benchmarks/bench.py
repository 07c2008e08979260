"""Speed of the warehouse environments, measured side by side with reference environments.

One run measures, on this machine:

- steps per second of Gymnasium's ``FrozenLake-v1`` (the reference),
  ``warehouse-robot-v0`` and ``warehouse-robot-phys-v0``, through ``gym.make``
  as users call them and unwrapped, with random actions and resets;
- frames per second of ``render_mode="rgb_array"`` for the same three;
- the wall time of 1000 training episodes with the default trainer on both
  warehouse environments, next to the classic tutorial's plain Q-learning loop;
- the physics: steps per action, the cost of one physics step (as the move loop
  runs it and through pymunk's ``Space.step``), of one move and of one reset.

Each figure is the median of several repeats and is printed with its ratio to
its reference and, where the project has one, its target. The results are
written as JSON (``--json``) so that runs can be compared.

    python benchmarks/bench.py [--quick] [--repeats K] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # rgb_array needs no window
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import gymnasium as gym
import numpy as np
import pymunk

import warehouse_phys
from warehouse_phys.atomic import atomic_write_text
from warehouse_phys.grid import WarehouseGrid
from warehouse_phys.layouts import suggested_time_limit
from warehouse_phys.physics import PhysicsConfig, PhysicsWorld
from warehouse_phys.qlearning import QLearningConfig, train

FROZEN_LAKE = "FrozenLake-v1"
GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID


@dataclass
class Figure:
    """One measured figure: the median of ``runs``, compared with a reference figure."""

    name: str
    unit: str
    runs: list[float]
    reference: str | None = None
    #: The project's target for the ratio to the reference, if it has one.
    target_ratio: float | None = None
    #: True when a larger value is better (a rate), False for times.
    higher_is_better: bool = True
    #: The project's target for the value itself (a time limit), if it has one.
    target_at_most: float | None = None
    value: float = field(init=False)

    def __post_init__(self) -> None:
        self.value = statistics.median(self.runs)


def repeat(measure: Callable[[], float], repeats: int) -> list[float]:
    return [measure() for _ in range(repeats)]


# ----------------------------------------------------------------- stepping
def actions_per_second(env: gym.Env, actions: list[int], render: bool = False) -> float:
    """Run ``actions`` (rendering after each if asked), resetting at episode ends."""
    env.reset(seed=0)
    step, reset = env.step, env.reset
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = step(action)
        if render:
            env.render()
        if terminated or truncated:
            reset()
    return len(actions) / (time.perf_counter() - start)


def stepping_figures(n_actions: int, repeats: int) -> list[Figure]:
    actions = np.random.default_rng(0).integers(4, size=n_actions).tolist()
    reference = f"{FROZEN_LAKE} (gym.make)"
    targets = {f"{GRID_ID} (gym.make)": 1.3, f"{PHYS_ID} (gym.make)": 0.15}
    figures = []
    for env_id in (FROZEN_LAKE, GRID_ID, PHYS_ID):
        for how in ("gym.make", "unwrapped"):
            name = f"{env_id} ({how})"

            def measure(env_id: str = env_id, how: str = how) -> float:
                env = gym.make(env_id)
                return actions_per_second(env if how == "gym.make" else env.unwrapped, actions)

            figures.append(
                Figure(name, "steps/s", repeat(measure, repeats), reference, targets.get(name))
            )
    return figures


def rendering_figures(n_frames: int, repeats: int) -> list[Figure]:
    actions = np.random.default_rng(1).integers(4, size=n_frames).tolist()
    reference = f"{FROZEN_LAKE} rgb_array"
    figures = []
    for env_id in (FROZEN_LAKE, GRID_ID, PHYS_ID):

        def measure(env_id: str = env_id) -> float:
            env = gym.make(env_id, render_mode="rgb_array")
            env.reset(seed=0)
            env.render()  # loads pygame and the sprites outside the timing
            rate = actions_per_second(env, actions, render=True)
            env.close()
            return rate

        target = None if env_id == FROZEN_LAKE else 1.0
        figures.append(
            Figure(f"{env_id} rgb_array", "frames/s", repeat(measure, repeats), reference, target)
        )
    return figures


# ----------------------------------------------------------------- training
def tutorial_loop(episodes: int, seed: int = 0) -> None:
    """The classic tutorial's training loop on the grid twin, seeded: the reference."""
    env = gym.make(GRID_ID)
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


def seconds(run: Callable[[], object]) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def training_figures(episodes: int, repeats: int) -> list[Figure]:
    config = QLearningConfig(episodes=episodes)
    reference = "tutorial loop (grid twin)"
    figures = [
        Figure(
            reference,
            "s",
            repeat(lambda: seconds(lambda: tutorial_loop(episodes)), repeats),
            higher_is_better=False,
        )
    ]
    # The targets are for the default 1000 episodes: at most 0.2 s and 3 s.
    limits = {GRID_ID: 0.2, PHYS_ID: 3.0} if episodes == 1000 else {}
    for env_id in (GRID_ID, PHYS_ID):

        def measure(env_id: str = env_id) -> float:
            return seconds(lambda: train(gym.make(env_id), config))

        figures.append(
            Figure(
                f"trainer on {env_id}",
                "s",
                repeat(measure, repeats),
                reference,
                higher_is_better=False,
                target_at_most=limits.get(env_id),
            )
        )
    return figures


# ------------------------------------------------------------------ physics
def physics_figures(repeats: int) -> list[Figure]:
    config = PhysicsConfig()
    grid = WarehouseGrid(4, 5)
    n = 2000
    moves = [0, 2, 1, 3] * (n // 4)  # round trips between two cells, some into walls

    def per_move() -> float:
        world = PhysicsWorld(grid, config, (1, 1))
        return seconds(lambda: [world.move(a) for a in moves]) / n * 1e6

    def per_step(space_step: bool) -> float:
        world = PhysicsWorld(grid, config, (1, 1))
        world.control.position = world.centre((1, 2))
        step, target = (pymunk.Space.step, world.space) if space_step else world._stepping()
        dt, count = config.dt, n * config.steps_per_move

        def run() -> None:
            for _ in range(count):
                step(target, dt)

        return seconds(run) / count * 1e6

    def per_reset() -> float:
        def run() -> None:
            for _ in range(n // 4):
                PhysicsWorld(grid, config, (0, 0))  # each replaces the last, as reset() does

        return seconds(run) / (n // 4) * 1e6

    fast = "physics step (move loop)"
    return [
        Figure("physics steps per action", "steps", [float(config.steps_per_move)]),
        Figure(fast, "us", repeat(lambda: per_step(False), repeats), higher_is_better=False),
        Figure(
            "physics step (Space.step)",
            "us",
            repeat(lambda: per_step(True), repeats),
            fast,
            higher_is_better=False,
        ),
        Figure("one move (world.move)", "us", repeat(per_move, repeats), higher_is_better=False),
        Figure("one reset (new world)", "us", repeat(per_reset, repeats), higher_is_better=False),
    ]


# -------------------------------------------------------------------- report
def world_model_figures(repeats: int) -> list[Figure]:
    """CPU seconds to build big floors and to give them a time limit."""

    def cpu_seconds(run: Callable[[], object]) -> float:
        start = time.process_time()
        run()
        return time.process_time() - start

    aisles = ["S" + "." * 255] + [
        ("." + "#" * 254 + ".") if r % 2 else "." * 256 for r in range(1, 256)
    ]
    figures = [
        Figure(
            "build a 256 x 256 floor of aisles",
            "s",
            repeat(lambda: cpu_seconds(lambda: WarehouseGrid.from_layout(aisles)), repeats),
            higher_is_better=False,
            target_at_most=1.0,
        )
    ]
    for size, target in ((10, 1.0), (100, 1.0), (256, 10.0)):
        grid = WarehouseGrid(size, size)
        figures.append(
            Figure(
                f"suggested_time_limit, {size} x {size}",
                "s",
                repeat(lambda grid=grid: cpu_seconds(lambda: suggested_time_limit(grid)), repeats),
                higher_is_better=False,
                target_at_most=target,
            )
        )
    return figures


def machine() -> dict[str, object]:
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "versions": {
            "warehouse_phys": warehouse_phys.__version__,
            "gymnasium": gym.__version__,
            "numpy": np.__version__,
            "pymunk": pymunk.version,
        },
    }


def report(sections: dict[str, list[Figure]]) -> str:
    lines = []
    for title, figures in sections.items():
        values = {f.name: f.value for f in figures}
        lines.append(f"\n{title}")
        lines.append(f"  {'':<42} {'median':>12} {'unit':<8} {'vs reference':>14}  target")
        for f in figures:
            ratio, verdict = "", ""
            if f.reference is not None:
                ratio_value = f.value / values[f.reference]
                ratio = f"{ratio_value:.2f}x"
                if f.target_ratio is not None:
                    met = ratio_value >= f.target_ratio
                    verdict = f">= {f.target_ratio:g}x: {'met' if met else 'MISSED'}"
            if f.target_at_most is not None:
                met = f.value <= f.target_at_most
                verdict = f"<= {f.target_at_most:g} {f.unit}: {'met' if met else 'MISSED'}"
            value = f"{f.value:,.0f}" if f.value >= 100 else f"{f.value:.3g}"
            lines.append(f"  {f.name:<42} {value:>12} {f.unit:<8} {ratio:>14}  {verdict}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny budgets: a smoke test")
    parser.add_argument("--repeats", type=int, default=5, help="runs per figure (median)")
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    repeats = 1 if args.quick else args.repeats
    budget = {
        "actions": 300 if args.quick else 100_000,
        "frames": 20 if args.quick else 500,
        "episodes": 20 if args.quick else 1000,
    }

    sections = {
        f"stepping ({budget['actions']:,} random actions, resets included)": stepping_figures(
            budget["actions"], repeats
        ),
        f"rendering rgb_array ({budget['frames']} steps, a frame after each)": rendering_figures(
            budget["frames"], repeats
        ),
        f"training ({budget['episodes']} episodes, default trainer)": training_figures(
            budget["episodes"], repeats
        ),
        "physics (default settings)": physics_figures(repeats),
        "world model (CPU time)": world_model_figures(repeats),
    }
    print(f"median of {repeats} run(s) each; {platform.python_version()}, {os.cpu_count()} CPUs")
    print(report(sections))
    results = {
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine(),
        "repeats": repeats,
        "budget": budget,
        "sections": {title: [asdict(f) for f in figures] for title, figures in sections.items()},
    }
    if args.json is not None:
        atomic_write_text(args.json, json.dumps(results, indent=2) + "\n")
        print(f"\nwrote {args.json}")
    return results


if __name__ == "__main__":
    main()
