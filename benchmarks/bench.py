"""Speed of the warehouse environments, measured against references in the same process.

The machine is shared and noisy, so no figure comes from one block of wall time.
Each group of figures is measured in interleaved *rounds*: in every round each
candidate and its reference run the same amount of work, one after the other
(the order rotates from round to round), timed with CPU time
(``time.process_time``). A figure reports the median over the rounds and its
range, and its ratio to the reference is taken within each round, so that a slow
moment of the machine slows both sides of the ratio.

Groups and references:

- stepping: ``warehouse-robot-v0`` and ``warehouse-robot-phys-v0`` (through
  ``gym.make`` and unwrapped) against Gymnasium's ``FrozenLake-v1``, random
  actions with resets;
- rendering: ``render_mode="rgb_array"`` frames against ``FrozenLake-v1``'s;
- training: 1000 episodes of the default trainer against the classic tutorial's
  plain Q-learning loop;
- vector: the native ``gym.make_vec("warehouse-robot-v0")`` against Gymnasium's
  ``SyncVectorEnv`` of the same environment, at several ``num_envs``;
- physics vector: the native ``gym.make_vec("warehouse-robot-phys-v0")`` against
  the single physics environment, in robot-actions per second, at several ``num_envs``;
- fleet: joint steps per second of a fleet (2, 8 and 16 robots, both worlds)
  against single physics-backed environment steps;
- fleet at scale: robot-steps per second of the grid fleet from 64 to 4,096 robots
  against the fleet of 64, and the PIBT planner's robot-steps planned per second;
- physics: a physics step (the move loop's, against ``Space.step``), a move, a reset;
- world model: building a big floor and suggesting time limits (no reference).

    python benchmarks/bench.py [--quick] [--rounds K] [--json PATH] [--only GROUP]
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
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.physics import PhysicsConfig, PhysicsWorld
from warehouse_phys.rl.qlearning import QLearningConfig, train
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import suggested_time_limit

FROZEN_LAKE = "FrozenLake-v1"
GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID
MIN_ROUNDS = 7


@dataclass
class Figure:
    """One measured figure: a value per round, and its ratio to the reference per round."""

    name: str
    unit: str
    rounds: list[float]
    reference: str | None = None
    #: The figure divided by its reference's, round by round.
    ratios: list[float] = field(default_factory=list)
    #: True when a larger value is better (a rate), False for times.
    higher_is_better: bool = True
    #: The project's target for the ratio to the reference (at least), if any.
    target_ratio: float | None = None
    #: The project's target for the value itself: at least (rates) or at most (times).
    target_value: float | None = None
    value: float = field(init=False)
    low: float = field(init=False)
    high: float = field(init=False)
    ratio: float | None = field(init=False)

    def __post_init__(self) -> None:
        self.value = statistics.median(self.rounds)
        self.low, self.high = min(self.rounds), max(self.rounds)
        self.ratio = statistics.median(self.ratios) if self.ratios else None

    @property
    def verdict(self) -> str:
        checks = []
        if self.target_ratio is not None and self.ratio is not None:
            met = self.ratio >= self.target_ratio
            checks.append(f">= {self.target_ratio:g}x: {'met' if met else 'MISSED'}")
        if self.target_value is not None:
            if self.higher_is_better:
                met, sign = self.value >= self.target_value, ">="
            else:
                met, sign = self.value <= self.target_value, "<="
            checks.append(f"{sign} {self.target_value:g} {self.unit}: {'met' if met else 'MISSED'}")
        return "; ".join(checks)


@dataclass
class Candidate:
    """Something to time: ``run()`` does a fixed amount of work and returns how much
    (steps, frames, ...); the figure is work per CPU second, or CPU seconds per
    ``per`` units of work for times."""

    name: str
    unit: str
    run: Callable[[], float]
    higher_is_better: bool = True
    per: float = 1.0
    target_ratio: float | None = None
    target_value: float | None = None
    #: The CPU seconds of the last run that count, if not all of them (``None``: all).
    cpu_seconds: Callable[[], float] | None = None


def interleaved(
    candidates: list[Candidate], rounds: int, reference: str | None = None
) -> list[Figure]:
    """Measure every candidate once per round, rotating the order; ratios to ``reference``."""
    values: dict[str, list[float]] = {c.name: [] for c in candidates}
    for round_index in range(rounds):
        shift = round_index % len(candidates)
        for candidate in candidates[shift:] + candidates[:shift]:
            start = time.process_time()
            work = candidate.run()
            seconds = time.process_time() - start
            if candidate.cpu_seconds is not None:
                seconds = candidate.cpu_seconds()
            seconds = max(seconds, 1e-9)
            if candidate.higher_is_better:
                values[candidate.name].append(work / seconds)
            else:
                values[candidate.name].append(seconds / work * candidate.per)
    figures = []
    for c in candidates:
        ratios = []
        if reference is not None and c.name != reference:
            ratios = [a / b for a, b in zip(values[c.name], values[reference], strict=True)]
        figures.append(
            Figure(
                c.name,
                c.unit,
                values[c.name],
                reference if c.name != reference else None,
                ratios,
                c.higher_is_better,
                c.target_ratio,
                c.target_value,
            )
        )
    return figures


# ----------------------------------------------------------------- stepping
def stepper(env: gym.Env, actions: list[int], render: bool = False) -> Callable[[], float]:
    """A run of ``actions`` (rendering after each if asked), resetting at episode ends."""
    env.reset(seed=0)
    if render:
        env.render()  # loads pygame and the sprites before any timing

    def run() -> float:
        step, reset = env.step, env.reset
        for action in actions:
            _, _, terminated, truncated, _ = step(action)
            if render:
                env.render()
            if terminated or truncated:
                reset()
        return len(actions)

    return run


def stepping_figures(n_actions: int, rounds: int) -> list[Figure]:
    actions = np.random.default_rng(0).integers(4, size=n_actions).tolist()
    targets = {f"{GRID_ID} (gym.make)": 4.0, f"{PHYS_ID} (gym.make)": 0.4}
    candidates = []
    for env_id in (FROZEN_LAKE, GRID_ID, PHYS_ID):
        for how in ("gym.make", "unwrapped"):
            name = f"{env_id} ({how})"
            env = gym.make(env_id)
            env = env if how == "gym.make" else env.unwrapped
            candidates.append(
                Candidate(name, "steps/s", stepper(env, actions), target_ratio=targets.get(name))
            )
    return interleaved(candidates, rounds, reference=f"{FROZEN_LAKE} (gym.make)")


def rendering_figures(n_frames: int, rounds: int) -> list[Figure]:
    actions = np.random.default_rng(1).integers(4, size=n_frames).tolist()
    candidates = [
        Candidate(
            f"{env_id} rgb_array",
            "frames/s",
            stepper(gym.make(env_id, render_mode="rgb_array"), actions, render=True),
            target_ratio=None if env_id == FROZEN_LAKE else 1.0,
        )
        for env_id in (FROZEN_LAKE, GRID_ID, PHYS_ID)
    ]
    return interleaved(candidates, rounds, reference=f"{FROZEN_LAKE} rgb_array")


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


def training_figures(episodes: int, rounds: int) -> list[Figure]:
    config = QLearningConfig(episodes=episodes)
    reference = "tutorial loop (grid twin)"

    def once(work: Callable[[], object]) -> Callable[[], float]:
        def run() -> float:
            work()
            return 1.0

        return run

    # The targets are for the default 1000 episodes: at most 0.2 s and 3 s.
    limits = {GRID_ID: 0.2, PHYS_ID: 3.0} if episodes == 1000 else {}
    candidates = [
        Candidate(reference, "s", once(lambda: tutorial_loop(episodes)), higher_is_better=False)
    ]
    for env_id in (GRID_ID, PHYS_ID):
        candidates.append(
            Candidate(
                f"trainer on {env_id}",
                "s",
                once(lambda env_id=env_id: train(gym.make(env_id), config)),
                higher_is_better=False,
                target_value=limits.get(env_id),
            )
        )
    return interleaved(candidates, rounds, reference=reference)


# ------------------------------------------------------------------- vector
def vector_stepper(envs: gym.vector.VectorEnv, env_steps: int) -> Callable[[], float]:
    """About ``env_steps`` sub-environment steps of random actions (autoreset included)."""
    n = envs.num_envs
    batches = np.random.default_rng(2).integers(4, size=(16, n))
    calls = max(1, env_steps // n)
    envs.reset(seed=0)

    def run() -> float:
        step = envs.step
        for i in range(calls):
            step(batches[i % 16])
        return calls * n

    return run


def vector_figures(sizes: list[int], env_steps: int, rounds: int) -> list[Figure]:
    """The native vector env against SyncVectorEnv, size by size (each its own rounds)."""
    targets = {256: 1e7, 16384: 1e8}
    figures = []
    for n in sizes:
        native = gym.make_vec(GRID_ID, num_envs=n)
        sync = gym.make_vec(GRID_ID, num_envs=n, vectorization_mode="sync")
        reference = f"SyncVectorEnv, {n} envs"
        figures += interleaved(
            [
                Candidate(reference, "env-steps/s", vector_stepper(sync, env_steps // 10)),
                Candidate(
                    f"native vector env, {n} envs",
                    "env-steps/s",
                    vector_stepper(native, env_steps),
                    target_value=targets.get(n),
                ),
            ],
            rounds,
            reference=reference,
        )
        sync.close()
    return figures


def chipmunk_timed(run: Callable[[], float]) -> tuple[Callable[[], float], Callable[[], float]]:
    """``run`` with every physics step of the batched world timed: the run, and the CPU
    seconds its last call spent inside chipmunk's ``cpSpaceStep``."""
    from warehouse_phys.physics import body_io as batched_physics  # where the world steps

    stepping = batched_physics.space_stepping
    inside = [0.0]

    def timed_stepping(space: object) -> tuple[Callable[..., None], object]:
        step, handle = stepping(space)

        def timed(handle: object, dt: float) -> None:
            start = time.process_time()
            step(handle, dt)
            inside[0] += time.process_time() - start

        return timed, handle

    def timed_run() -> float:
        inside[0] = 0.0
        batched_physics.space_stepping = timed_stepping
        try:
            return run()
        finally:
            batched_physics.space_stepping = stepping

    return timed_run, lambda: inside[0]


def physics_vector_figures(sizes: list[int], robot_actions: int, rounds: int) -> list[Figure]:
    """The native physics vector env against the single physics env (``gym.make``), size by
    size: robot-actions per CPU second, each size in its own rounds. At 256 envs also
    chipmunk alone: the robot-actions per CPU second spent inside ``cpSpaceStep`` in a
    third env of the same rounds, the rate the vector env would reach with no Python
    at all, so its ratio bounds the vector env's."""
    single_actions = np.random.default_rng(3).integers(4, size=robot_actions // 4).tolist()
    figures = []
    for n in sizes:
        native = gym.make_vec(PHYS_ID, num_envs=n)
        reference = f"gym.make physics env, beside {n} envs"
        candidates = [
            Candidate(reference, "robot-actions/s", stepper(gym.make(PHYS_ID), single_actions)),
            Candidate(
                f"native physics vector env, {n} envs",
                "robot-actions/s",
                vector_stepper(native, robot_actions),
                target_ratio=3.5 if n == 256 else None,
                target_value=2e5 if n == 256 else None,
            ),
        ]
        if n == 256:
            timed_run, inside = chipmunk_timed(
                vector_stepper(gym.make_vec(PHYS_ID, num_envs=n), robot_actions)
            )
            candidates.append(
                Candidate(
                    f"chipmunk alone in the physics vector env, {n} envs",
                    "robot-actions/s",
                    timed_run,
                    cpu_seconds=inside,
                )
            )
        figures += interleaved(candidates, rounds, reference=reference)
    return figures


# -------------------------------------------------------------------- fleet
def random_joint_actions(env: object, joint_steps: int, seed: int) -> list[dict[str, int]]:
    """``joint_steps`` joint actions (WAIT included) for every robot of the fleet ``env``,
    drawn uniformly from their own generator."""
    names = env.possible_agents
    rows = np.random.default_rng(seed).integers(5, size=(joint_steps, len(names))).tolist()
    return [dict(zip(names, row, strict=True)) for row in rows]


def fleet_stepper(robots: int, physics: bool, joint_steps: int) -> Callable[[], float]:
    """Random joint actions (WAIT included) for a lifelong fleet on an 8 x 10 floor."""
    from warehouse_phys.envs.fleet import parallel_env

    env = parallel_env(
        num_robots=robots, physics=physics, grid_rows=8, grid_cols=10, lifelong=True,
        max_cycles=10**9,
    )  # fmt: skip
    env.reset(seed=0)
    joint = random_joint_actions(env, joint_steps, seed=4)

    def run() -> float:
        step = env.step
        for actions in joint:
            step(actions)
        return len(joint)

    return run


def fleet_figures(sizes: list[int], joint_steps: int, rounds: int) -> list[Figure]:
    """Joint steps per second of a fleet in both worlds, against single physics env steps."""
    reference = f"single {PHYS_ID} step (gym.make)"
    actions = np.random.default_rng(5).integers(4, size=joint_steps).tolist()
    candidates = [Candidate(reference, "steps/s", stepper(gym.make(PHYS_ID), actions))]
    for physics in (False, True):
        for n in sizes:
            candidates.append(
                Candidate(
                    f"fleet of {n}, {'physics' if physics else 'grid twin'}",
                    "joint steps/s",
                    fleet_stepper(n, physics, joint_steps),
                    # An 8-robot physics joint step costs at most 3 single physics steps.
                    target_ratio=1 / 3 if physics and n == 8 else None,
                )
            )
    return interleaved(candidates, rounds, reference=reference)


def fleet_scale_stepper(robots: int, joint_steps: int) -> Callable[[], float]:
    """Random joint actions (WAIT included) for a lifelong grid fleet on a 128 x 128 floor,
    robots on random distinct cells; counts robot-steps."""
    from warehouse_phys.envs.fleet import parallel_env

    env = parallel_env(
        num_robots=robots, grid_rows=128, grid_cols=128, on_delivery="new_package",
        starts="random", max_cycles=10**9,
    )  # fmt: skip
    env.reset(seed=0)
    joint = random_joint_actions(env, joint_steps, seed=6)

    def run() -> float:
        step = env.step
        for actions in joint:
            step(actions)
        return len(joint) * robots

    return run


def planner_stepper(robots: int, joint_steps: int) -> Callable[[], float]:
    """The PIBT planner's plans alone (no env step between them: the same situation
    planned again) on the ``warehouse`` preset, lifelong; counts robot-steps planned."""
    from warehouse_phys.envs.fleet import parallel_env
    from warehouse_phys.rl.fleet_planners import pibt_policy

    env = parallel_env(num_robots=robots, layout="warehouse", on_delivery="new_package")
    observations, infos = env.reset(seed=0)
    policy = pibt_policy(seed=0)
    actions = policy(env, observations, infos)  # builds the distance maps
    env.step(actions)

    def run() -> float:
        for _ in range(joint_steps):
            policy(env, observations, infos)
        return joint_steps * robots

    return run


def fleet_scale_figures(sizes: list[int], robot_steps: int, rounds: int) -> list[Figure]:
    """Robot-steps per second of the grid fleet as it grows, against the largest fleet
    below 4,096 (1,024 in a full run): the cost per robot should stay within 1.5x of it
    at every size."""
    reference = max(n for n in sizes if n <= 1024)
    candidates = []
    for n in sizes:
        candidates.append(
            Candidate(
                f"grid fleet of {n:,}",
                "robot-steps/s",
                fleet_scale_stepper(n, max(1, robot_steps // n)),
                # The cost per robot within 1.5x of the reference fleet's, 64 to 4,096.
                target_ratio=1 / 1.5 if n != reference else None,
                target_value=1e6 if n == 1024 else None,
            )
        )
    candidates.append(
        Candidate("PIBT plan, 192 robots on warehouse", "robot-steps/s",
                  planner_stepper(192, max(1, robot_steps // 192 // 4)))
    )  # fmt: skip
    return interleaved(candidates, rounds, reference=f"grid fleet of {reference:,}")


def physics_fleet_stepper(
    robots: int, joint_steps: int, track_gaps: bool, chipmunk: list[float] | None = None
) -> Callable[[], float]:
    """Random joint actions (WAIT included) for a lifelong physics fleet on a 64 x 64
    floor, robots on random distinct cells; counts joint steps. With ``chipmunk``, each
    run appends the CPU time spent inside chipmunk's ``cpSpaceStep`` to it."""
    from warehouse_phys.envs.fleet import parallel_env

    env = parallel_env(
        num_robots=robots, physics=True, grid_rows=64, grid_cols=64, lifelong=True,
        starts="random", max_cycles=10**9, track_gaps=track_gaps,
    )  # fmt: skip
    env.reset(seed=0)
    joint = random_joint_actions(env, joint_steps, seed=7)

    def run() -> float:
        step = env.step
        for actions in joint:
            step(actions)
        return len(joint)

    if chipmunk is None:
        return run
    timed_run, inside = chipmunk_timed(run)  # every physics step of this run, only of it

    def recorded() -> float:
        done = timed_run()
        chipmunk.append(inside())
        return done

    return recorded


def physics_fleet_figures(sizes: list[int], joint_steps: int, rounds: int) -> list[Figure]:
    """Joint steps per second of the physics fleet with and without ``min_gap``, against
    the fleet of the smallest size with it; and chipmunk's share of a joint step."""
    candidates = []
    for n in sizes:
        steps = max(2, joint_steps * sizes[0] // n)
        for track_gaps in (True, False):
            candidates.append(
                Candidate(
                    f"physics fleet of {n:,}{'' if track_gaps else ', track_gaps=False'}",
                    "joint steps/s",
                    physics_fleet_stepper(n, steps, track_gaps),
                )
            )
    figures = interleaved(candidates, rounds, reference=candidates[0].name)
    for track_gaps in (True, False):  # timed apart: timing each physics step costs a little
        chipmunk: list[float] = []
        run = physics_fleet_stepper(256, max(2, joint_steps // 4), track_gaps, chipmunk)
        shares = []
        for _ in range(rounds):
            start = time.process_time()
            run()
            shares.append(100 * chipmunk[-1] / (time.process_time() - start))
        figures.append(
            Figure(
                f"chipmunk's share at 256{'' if track_gaps else ', track_gaps=False'}",
                "% of the CPU time",
                shares,
                target_value=50,
            )
        )
    return figures


# ------------------------------------------------------------------ physics
def physics_figures(rounds: int) -> list[Figure]:
    config = PhysicsConfig()
    grid = WarehouseGrid(4, 5)
    n = 2000
    moves = [0, 2, 1, 3] * (n // 4)  # round trips between two cells, some into walls

    def stepping(space_step: bool) -> Callable[[], float]:
        world = PhysicsWorld(grid, config, (1, 1))
        world.control.position = world.centre((1, 2))
        step, target = (pymunk.Space.step, world.space) if space_step else world._stepping()
        dt, count = config.dt, n * config.steps_per_move

        def run() -> float:
            for _ in range(count):
                step(target, dt)
            return count

        return run

    world = PhysicsWorld(grid, config, (1, 1))

    def per_move() -> float:
        for action in moves:
            world.move(action)
        return n

    def per_reset() -> float:
        for _ in range(n // 4):
            PhysicsWorld(grid, config, (0, 0))
        return n // 4

    restarted = PhysicsWorld(grid, config, (0, 0))

    def per_restart() -> float:
        for _ in range(n // 4):
            restarted.restart((0, 0))
        return n // 4

    reference = "physics step (Space.step)"
    steps = interleaved(
        [
            Candidate(reference, "us", stepping(True), higher_is_better=False, per=1e6),
            Candidate("physics step (move loop)", "us", stepping(False), False, per=1e6),
        ],
        rounds,
        reference=reference,
    )
    return steps + interleaved(  # no reference for these: what a move and a reset cost
        [
            Candidate("one move (world.move)", "us", per_move, higher_is_better=False, per=1e6),
            Candidate("a new world", "us", per_reset, higher_is_better=False, per=1e6),
            Candidate(
                "one reset (world.restart)", "us", per_restart, higher_is_better=False, per=1e6
            ),
        ],
        rounds,
    )


def world_model_figures(rounds: int) -> list[Figure]:
    """CPU seconds to build a big floor and to give floors a time limit."""
    aisles = ["S" + "." * 255] + [
        ("." + "#" * 254 + ".") if r % 2 else "." * 256 for r in range(1, 256)
    ]

    def timed(work: Callable[[], object]) -> Callable[[], float]:
        def run() -> float:
            work()
            return 1.0

        return run

    candidates = [
        Candidate(
            "build a 256 x 256 floor of aisles",
            "s",
            timed(lambda: WarehouseGrid.from_layout(aisles)),
            higher_is_better=False,
            target_value=1.0,
        )
    ]
    for size, target in ((10, 1.0), (100, 1.0), (256, 10.0)):
        grid = WarehouseGrid(size, size)
        candidates.append(
            Candidate(
                f"suggested_time_limit, {size} x {size}",
                "s",
                timed(lambda grid=grid: suggested_time_limit(grid)),
                higher_is_better=False,
                target_value=target,
            )
        )
    return interleaved(candidates, rounds)


# ------------------------------------------------------------------ report
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


def _number(value: float) -> str:
    if value >= 100:
        return f"{value:,.0f}"
    return f"{value:.3g}"


def report(sections: dict[str, list[Figure]]) -> str:
    lines = []
    for title, figures in sections.items():
        lines.append(f"\n{title}")
        lines.append(
            f"  {'':<40} {'median':>12} {'min - max':>25} {'unit':<12} {'vs reference':>20}  target"
        )
        for f in figures:
            spread = f"{_number(f.low)} - {_number(f.high)}"
            ratio = ""
            if f.ratio is not None:
                ratio = f"{f.ratio:.2f}x ({min(f.ratios):.2f}-{max(f.ratios):.2f})"
            elif f.reference is None and any(g.reference == f.name for g in figures):
                ratio = "reference"
            lines.append(
                f"  {f.name:<40} {_number(f.value):>12} {spread:>25} {f.unit:<12} "
                f"{ratio:>20}  {f.verdict}".rstrip()
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny budgets: a smoke test")
    parser.add_argument(
        "--rounds",
        type=int,
        default=MIN_ROUNDS,
        help=f"interleaved rounds per group (default and least for a report: {MIN_ROUNDS})",
    )
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    parser.add_argument(
        "--only",
        metavar="TEXT",
        help="run only the groups whose title starts with TEXT (e.g. 'physics vector')",
    )
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error("--rounds must be at least 1")
    rounds = 2 if args.quick else args.rounds
    budget = {
        "actions": 300 if args.quick else 20_000,
        "frames": 10 if args.quick else 100,
        "episodes": 20 if args.quick else 1000,
        "vector_sizes": [1, 64] if args.quick else [1, 64, 256, 1024, 16384],
        "vector_env_steps": 5_000 if args.quick else 400_000,
        "physics_vector_sizes": [1, 16] if args.quick else [1, 16, 64, 256, 1024],
        "physics_vector_robot_actions": 400 if args.quick else 20_000,
        "fleet_sizes": [2, 8] if args.quick else [2, 8, 16],
        "fleet_joint_steps": 50 if args.quick else 1000,
        "fleet_scale_sizes": [64, 256] if args.quick else [64, 256, 1024, 4096],
        "fleet_scale_robot_steps": 2_000 if args.quick else 200_000,
        "physics_fleet_sizes": [64, 256] if args.quick else [64, 256, 1024],
        "physics_fleet_joint_steps": 8 if args.quick else 400,
    }
    groups = {  # made lazily: --only runs some
        f"stepping ({budget['actions']:,} random actions a round, resets included)": lambda: (
            stepping_figures(budget["actions"], rounds)
        ),
        f"rendering rgb_array ({budget['frames']} steps a round, a frame after each)": lambda: (
            rendering_figures(budget["frames"], rounds)
        ),
        f"training ({budget['episodes']} episodes a round, default trainer)": lambda: (
            training_figures(budget["episodes"], rounds)
        ),
        "vector (random actions, autoreset included)": lambda: vector_figures(
            budget["vector_sizes"], budget["vector_env_steps"], rounds
        ),
        "physics vector (random actions, autoreset included)": lambda: physics_vector_figures(
            budget["physics_vector_sizes"], budget["physics_vector_robot_actions"], rounds
        ),
        "fleet (random joint actions on an 8 x 10 floor, lifelong)": lambda: fleet_figures(
            budget["fleet_sizes"], budget["fleet_joint_steps"], rounds
        ),
        "fleet at scale (grid twin, random joint actions, lifelong, 128 x 128)": lambda: (
            fleet_scale_figures(
                budget["fleet_scale_sizes"], budget["fleet_scale_robot_steps"], rounds
            )
        ),
        "physics fleet at scale (random joint actions, lifelong, 64 x 64)": lambda: (
            physics_fleet_figures(
                budget["physics_fleet_sizes"], budget["physics_fleet_joint_steps"], rounds
            )
        ),
        "physics (default settings)": lambda: physics_figures(rounds),
        "world model": lambda: world_model_figures(rounds),
    }
    chosen = [title for title in groups if args.only is None or title.startswith(args.only)]
    if not chosen:
        parser.error(f"--only {args.only!r} names no group; the groups are {list(groups)}")
    sections = {title: groups[title]() for title in chosen}
    print(
        f"median of {rounds} interleaved round(s), CPU time; "
        f"Python {platform.python_version()}, {os.cpu_count()} CPUs"
    )
    print(report(sections))
    results = {
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine(),
        "rounds": rounds,
        "timer": "time.process_time",
        "budget": budget,
        "sections": {title: [asdict(f) for f in figures] for title, figures in sections.items()},
    }
    if args.json is not None:
        atomic_write_text(args.json, json.dumps(results, indent=2) + "\n")
        print(f"\nwrote {args.json}")
    return results


if __name__ == "__main__":
    main()
