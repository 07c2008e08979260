"""``python -m warehouse_phys.simulate``: run a fleet policy on a floor and measure it.

    python -m warehouse_phys.simulate --layout ../shared/maps/kiva-33-46.map --robots 192
    python -m warehouse_phys.simulate --layout warehouse --robots 128 --policy shortest
    python -m warehouse_phys.simulate --layout aisles --robots 4 --on-delivery park \\
        --policy runs/grid-aisles-seed0-.../qtable.npz
    python -m warehouse_phys.simulate --moves rotate \\
        --instance ../shared/lorr/2023-main-warehouse/MR23-I-10.json

A fleet of ``--robots`` robots on ``--layout`` (a preset, a ``.map`` file or a text
layout file; or ``--rows``/``--cols``) follows ``--policy`` for ``--steps`` joint
steps: ``pibt`` (the planner of :mod:`warehouse_phys.planners.pibt`), ``shortest``
(each robot a shortest move, waiting when blocked), ``random``, or a fleet table
written by ``python -m warehouse_phys.train --robots N``. ``--on-delivery``
(default ``new_package``: lifelong) says what a robot does with a delivered
package; ``--physics`` drives the physics twin. The command prints the throughput
(deliveries per step), deliveries, waits and refused moves (one-shot, also the
packages delivered, the makespan, the sum of costs against the shortest paths' and
the packages walled off); when it is cheap (robots x steps at most
:data:`COMPARE_BUDGET` on the grid; ``--no-compare`` skips it) it runs the
shortest-path and random baselines on the same floor, seed and steps and names a
policy that does worse. It writes a run folder (default
``runs/simulate-<floor>-<robots>-<policy>-seed<seed>-<time>``): ``summary.json``
(with the comparison), ``throughput.png`` (deliveries over time), ``congestion.png``
(waits on each cell) and ``fleet.gif`` (``--frames`` frames evenly spread, sized to
fit a 1000-pixel frame). Bad arguments end with exit status 2 and a one-line message.

``--instance X.json`` runs a League of Robot Runners problem instead
(:mod:`warehouse_phys.lorr.instances`: its floor, robots, starts and task list;
``--steps`` 5,000 by default, as the competition counts): it reports errands and
tasks finished a step, beside the published figure where the instance is one of
:data:`~warehouse_phys.lorr.instances.PUBLISHED_FIGURES`, and also writes
``lorr-output.json``, the competition's output file
(:mod:`warehouse_phys.lorr.output`), which its own tools and viewer read.
``--moves rotate`` gives the robots the competition's model (turn in place, drive
forward), on any floor.

**Ticks and delays** (League of Robot Runners 2026): an instance that names
``agentCounter`` or ``delayConfig``, or ``--ticks-per-move N`` / ``--p-delay P``
(``--delay-seed S``) on any instance or floor, runs the asynchronous fleet instead: moves
take ticks, robots are delayed at random, an executor keeps them apart, and ``--steps``
counts ticks (an instance's 5,000 by default, as LoRR 2026 counts; a floor's 256 moves'
worth). It reports errands and tasks a tick and a move-duration, the robot-ticks stood
still by own and knock-on delays and the mean drift; its ``lorr-output.json`` adds
``agentMaxCounter`` and ``delayIntervals``. ``--moves rotate`` turns LoRR's robots on
ticks too: :mod:`warehouse_phys.apps.simulate_async` has the details.

``summary.json`` records the CPU time of the reset, of the first step and the median and
slowest of the others (frames apart), and of the frames.
SIGTERM stops it as Ctrl-C does (exit status 143).

One command line: its length is its options, its measures and its run folder.
"""

from __future__ import annotations

import argparse
import functools
import gc
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from warehouse_phys.apps.cli import (
    MAX_CLI_ROBOTS,
    ArgumentParser,
    UsageError,
    bounded_int,
    floor_from_layout,
    opened_run_folder,
    written_note,
)
from warehouse_phys.apps.interrupts import interruption, stops_on_sigterm
from warehouse_phys.envs.fleet import DELIVERY_MODES, WarehouseFleetEnv, parallel_env
from warehouse_phys.lorr.instances import PUBLISHED_FIGURES, SCHEDULED, read_instance
from warehouse_phys.lorr.output import RunRecord, actual_actions, write_output
from warehouse_phys.lorr.scheduling import SCHEDULERS
from warehouse_phys.rl.fleet_evaluation import (
    FleetPolicy,
    compare_policies,
    random_fleet_policy,
    shortest_path_policy,
    walled_off_packages,
    worse_policies,
)
from warehouse_phys.world.headings import MOVE_MODELS
from warehouse_phys.world.layouts import FLEET_PRESETS, PRESETS

PROG = "python -m warehouse_phys.simulate"
POLICIES = ("pibt", "guided", "shortest", "random")
RUN_FILES = ("summary.json", "throughput.png", "congestion.png", "fleet.gif", "lorr-output.json")
DEFAULT_RUNS_DIR = Path("runs")
#: Frames of the GIF by default: enough to see the traffic, few enough to stay small.
DEFAULT_FRAMES = 64
#: The baselines a run is compared with, when that is cheap.
BASELINES = ("shortest", "random")
#: Robot-steps (robots x steps) up to which the command also runs the baselines: a few
#: seconds on the grid; the physics world is never compared.
COMPARE_BUDGET = 200_000
#: Steps of a run by default, and of an instance's (the competition's count).
DEFAULT_STEPS, INSTANCE_STEPS = 256, 5000


@dataclass(frozen=True)
class Simulation:
    """What a fleet did in one run of :func:`simulate`."""

    layout: str
    robots: int
    policy: str
    seed: int
    on_delivery: str
    physics: bool
    #: Deliveries at each joint step.
    deliveries: np.ndarray
    #: Waits counted on each cell, ``(rows, cols)``: a robot that had not delivered and
    #: stayed on its cell for a step (asked to WAIT, refused or bumping).
    waits: np.ndarray
    #: Moves that traffic turned into waits.
    refused: int
    #: Seconds of CPU time the steps took, the environment and the policy together
    #: (frames apart; the reset is ``reset_seconds``).
    cpu_seconds: float
    #: One-shot runs only (``on_delivery`` ``"park"`` or ``"leave"``): the step at which
    #: each robot delivered, 0 for a robot that did not, ``(robots,)``.
    delivered_at: np.ndarray | None = None
    #: One-shot runs only: each robot's shortest path to its package from its start.
    shortest: np.ndarray | None = None
    #: One-shot runs only: undelivered packages that parked robots wall off at the end.
    walled_off: int = 0
    #: CPU seconds of the reset, and of each step (policy and environment, no frames).
    reset_seconds: float = 0.0
    step_seconds: np.ndarray | None = None
    #: CPU seconds of drawing each frame.
    frame_seconds: np.ndarray | None = None
    #: ``"grid"`` or ``"rotate"``.
    moves: str = "grid"
    #: An instance run: the instance's name and the tasks finished at each step.
    instance: str | None = None
    #: What of the instance this run does not model, in words (a lock-step run of a 2026
    #: instance: its ticks and delays; a run on ticks: turning robots, square robots).
    not_simulated: tuple[str, ...] = ()
    tasks: np.ndarray | None = None
    #: A 2024 or later instance's scheduler, by its name (None for the others).
    scheduler: str | None = None

    @property
    def steps(self) -> int:
        return len(self.deliveries)

    @property
    def one_shot(self) -> bool:
        return self.delivered_at is not None

    @property
    def delivered(self) -> int:
        """Robots that delivered their package (one-shot), or deliveries (lifelong)."""
        if self.delivered_at is None:
            return int(self.deliveries.sum())
        return int(np.count_nonzero(self.delivered_at))

    @property
    def makespan(self) -> int:
        """One-shot: the step of the last delivery, or the run's length when a robot did
        not deliver."""
        if self.delivered_at is None or not self.delivered_at.all():
            return self.steps
        return int(self.delivered_at.max()) if len(self.delivered_at) else 0

    @property
    def sum_of_costs(self) -> int:
        """One-shot: each robot's steps until it delivered, an undelivered robot counted at
        the run's length, summed."""
        if self.delivered_at is None:
            return 0
        return int(np.where(self.delivered_at > 0, self.delivered_at, self.steps).sum())

    @property
    def throughput(self) -> float:
        """Deliveries per step."""
        return float(self.deliveries.mean()) if self.steps else 0.0

    def measures(self) -> str:
        """The measures in one line: throughput, deliveries, waits and refused moves; and
        one-shot, the makespan and the sum of costs against the shortest paths'; an
        instance run counts errands and tasks, beside the published figure."""
        if self.tasks is not None:
            return self._instance_measures()
        line = (
            f"throughput {self.throughput:.2f} deliveries/step, "
            f"{int(self.deliveries.sum()):,} deliveries, {int(self.waits.sum()):,} waits, "
            f"{self.refused:,} refused moves"
        )
        if self.delivered_at is not None and self.shortest is not None:
            walled = f" ({self.walled_off:,} walled off)" if self.walled_off else ""
            line += (
                f"; {self.delivered:,}/{self.robots:,} delivered{walled}, makespan "
                f"{self.makespan}, sum of costs {self.sum_of_costs:,} against "
                f"{int(self.shortest.sum()):,} on shortest paths"
            )
        return line

    def _instance_measures(self) -> str:
        steps = max(self.steps, 1)
        errands, tasks = int(self.deliveries.sum()), int(self.tasks.sum())
        line = (
            f"{errands / steps:.2f} errands/step, {tasks / steps:.2f} tasks/step ({errands:,} "
            f"errands, {tasks:,} tasks), {int(self.waits.sum()):,} waits, "
            f"{self.refused:,} refused moves"
        )
        published = PUBLISHED_FIGURES.get(self.instance or "")
        if published is not None:
            line += f"; published on {self.instance}: {published.describe()}"
        return line

    def lorr_output_options(self) -> dict[str, Any]:
        """Keywords of :func:`~warehouse_phys.lorr.output.write_output` beyond the
        record: none in lock step (a run on ticks adds its ticks and delays)."""
        return {}

    def figure_options(self) -> dict[str, Any]:
        """Keywords of :func:`~warehouse_phys.viz.plots.throughput_figure`: none in lock
        step (a run on ticks counts ticks)."""
        return {}

    def summary(self) -> str:
        what = "" if self.tasks is None else f", {self.moves} moves"
        return (
            f"{self.policy}, {self.robots:,} robots on {self.layout}, {self.steps} steps "
            f"({self.on_delivery}{what}): {self.measures()}"
        )

    def timing(self) -> dict[str, float]:
        """CPU seconds: the reset, the first step, the median and the slowest of the others
        (no step counts a frame); the frames' drawing, all together and the median one."""
        times = np.zeros(0) if self.step_seconds is None else self.step_seconds
        frames = np.zeros(0) if self.frame_seconds is None else self.frame_seconds
        later = times[1:] if len(times) > 1 else times
        return {
            "reset": self.reset_seconds,
            "first_step": float(times[0]) if len(times) else 0.0,
            "median_step": float(np.median(later)) if len(later) else 0.0,
            "max_step": float(later.max()) if len(later) else 0.0,
            "frames": float(frames.sum()),
            "median_frame": float(np.median(frames)) if len(frames) else 0.0,
        }

    def to_json(self) -> dict[str, Any]:
        return {
            "layout": self.layout,
            "robots": self.robots,
            "policy": self.policy,
            "seed": self.seed,
            "on_delivery": self.on_delivery,
            "physics": self.physics,
            "steps": self.steps,
            "throughput": self.throughput,
            "deliveries": int(self.deliveries.sum()),
            "waits": int(self.waits.sum()),
            "refused": self.refused,
            "cpu_seconds": self.cpu_seconds,
            "cpu_seconds_of": self.timing(),
            "moves": self.moves,
            **self._one_shot_json(),
            **self._instance_json(),
            "deliveries_per_step": self.deliveries.tolist(),
        }

    def _instance_json(self) -> dict[str, Any]:
        if self.tasks is None:
            return {}
        steps = max(self.steps, 1)
        published = PUBLISHED_FIGURES.get(self.instance or "")
        return {
            "instance": self.instance,
            "errands": int(self.deliveries.sum()),
            "errands_per_step": int(self.deliveries.sum()) / steps,
            "tasks": int(self.tasks.sum()),
            "tasks_per_step": int(self.tasks.sum()) / steps,
            "published": None if published is None else published.to_json(),
            "not_simulated": list(self.not_simulated),
            "scheduler": self.scheduler,
            "tasks_per_step_series": self.tasks.tolist(),
        }

    def _one_shot_json(self) -> dict[str, Any]:
        if self.delivered_at is None or self.shortest is None:
            return {}
        return {
            "delivered": self.delivered,
            "undelivered": self.robots - self.delivered,
            "walled_off": self.walled_off,
            "makespan": self.makespan,
            "sum_of_costs": self.sum_of_costs,
            "shortest_paths": int(self.shortest.sum()),
        }


def make_policy(name: str, env: WarehouseFleetEnv, *, seed: int) -> FleetPolicy:
    """The fleet policy called ``name``: one of :data:`POLICIES` or a fleet table's path.

    Raises:
        ValueError: for an unknown name, or a table that does not fit ``env``'s floor.
    """
    if name == "pibt":
        from warehouse_phys.planners.pibt import pibt_policy

        return pibt_policy(seed=seed)
    if name == "guided":
        from warehouse_phys.rl.fleet_planners import guided_pibt_policy

        return guided_pibt_policy(seed=seed)
    if name == "shortest":
        return shortest_path_policy
    if name == "random":
        return random_fleet_policy(seed)
    if name.endswith(".npz"):
        from warehouse_phys.rl.fleet_learning import greedy_fleet_policy
        from warehouse_phys.rl.qlearning import QTableError, load_q_table

        try:
            q, _ = load_q_table(name, rows=env.grid.rows, cols=env.grid.cols)
        except QTableError as error:
            raise ValueError(str(error)) from None
        expected = [*env.observation_space(env.possible_agents[0]).nvec.tolist(), 5]
        if list(q.shape) != expected:
            raise ValueError(
                f"{name}: a table of shape {q.shape} does not fit this fleet's observations "
                f"(expected {tuple(expected)})"
            )
        return greedy_fleet_policy(q)
    raise ValueError(f"unknown policy {name!r}: choose {', '.join(POLICIES)} or a table (.npz)")


def simulate(
    env: WarehouseFleetEnv,
    policy: FleetPolicy,
    *,
    steps: int,
    seed: int = 0,
    frames: int = 0,
    on_step: Any = None,
    name: str = "policy",
    layout: str = "",
    cell_px: int | None = None,
    record: RunRecord | None = None,
) -> tuple[Simulation, list[np.ndarray]]:
    """Play ``policy`` on ``env`` from ``env.reset(seed=seed)`` for ``steps`` joint steps
    (fewer if every robot finished); returns the measures and ``min(frames, steps + 1)``
    map frames (:func:`~warehouse_phys.drawing.render.fleet_map_frame`, ``cell_px`` pixels a cell,
    by default what fits 1000 pixels), the first at the reset, the last after the last
    step, evenly spread (fewer when the episode ends early).
    ``on_step()`` is called after each step (a progress bar); ``record`` (a
    :class:`~warehouse_phys.lorr.output.RunRecord`) gets every step's planned and
    actual actions (an instance fleet's, for the competition's output file)."""
    from warehouse_phys.drawing.render import fleet_map_frame

    started = time.process_time()
    observations, infos = env.reset(seed=seed)
    reset_seconds = time.process_time() - started
    grid, cols = env.grid, env.grid.cols
    waits = np.zeros(grid.rows * cols, dtype=np.int64)
    cells, packages = env.robot_cells, env.package_cells
    shortest = env.distances.lookup(
        cells[:, 0] * cols + cells[:, 1], packages[:, 0] * cols + packages[:, 1]
    ).astype(np.int64)
    delivered_at = np.zeros(env.num_robots, dtype=np.int64)
    deliveries, refused, pictures = [], 0, []
    # The steps after which a frame is taken (0: at the reset), evenly spread.
    shots = np.unique(np.linspace(0, steps, min(frames, steps + 1)).round().astype(int))

    frame_seconds: list[float] = []

    def picture() -> None:
        begun = time.process_time()
        pictures.append(fleet_map_frame(grid, env.robot_cells, env.package_cells, cell_px=cell_px,
                                        parked=env.parked, on_floor=env.on_floor,
                                        headings=env.robot_headings))  # fmt: skip
        frame_seconds.append(time.process_time() - begun)

    if frames:
        picture()
    shot = 1  # the next of shots to take
    errands = env.errands
    tasks_at: list[int] = []
    step_seconds: list[float] = []
    for step in range(steps):
        if not env.agents:
            break
        before = env.robot_cells.copy()
        headings_before = None if env.robot_headings is None else env.robot_headings.copy()
        working = env.on_floor & ~env.parked
        busy = None if errands is None else errands.goals >= 0
        tasks_before = 0 if errands is None else errands.tasks_done
        begun = time.process_time()
        actions = policy(env, observations, infos)
        planned = time.process_time()
        delivered_before = int(env.deliveries.sum())
        observations, _, _, _, infos = env.step(actions)
        step_seconds.append(time.process_time() - begun)
        if errands is not None:
            tasks_at.append(errands.tasks_done - tasks_before)
        if record is not None:
            _record_step(record, env, actions, before, headings_before, busy, planned - begun)
        if len(observations) != len(env.agents):
            observations = {agent: observations[agent] for agent in env.agents}
        deliveries.append(int(env.deliveries.sum()) - delivered_before)
        delivered_at[(env.deliveries > 0) & (delivered_at == 0)] = step + 1
        refused += sum(info["refused"] for info in infos.values())
        stayed = working & (env.robot_cells == before).all(axis=1)
        np.add.at(waits, before[stayed, 0] * cols + before[stayed, 1], 1)
        if shot < len(shots) and shots[shot] == step + 1:
            picture()
            shot += 1
        if on_step is not None:
            on_step()
    result = Simulation(
        layout=layout or f"{grid.rows}x{grid.cols}",
        robots=env.num_robots,
        policy=name,
        seed=seed,
        on_delivery=env.on_delivery,
        physics=env.physics,
        deliveries=np.array(deliveries, dtype=np.int64),
        waits=waits.reshape(grid.rows, grid.cols),
        refused=int(refused),
        cpu_seconds=float(sum(step_seconds)),
        reset_seconds=reset_seconds,
        step_seconds=np.array(step_seconds),
        frame_seconds=np.array(frame_seconds),
        moves=env.moves,
        instance=None if env.instance is None else env.instance.name,
        not_simulated=_not_simulated(env.instance),
        tasks=None if errands is None else np.array(tasks_at, dtype=np.int64),
        scheduler=_scheduler_name(errands),
        **(
            {}
            if env.lifelong
            else {
                "delivered_at": delivered_at,
                "shortest": shortest,
                "walled_off": walled_off_packages(env) if not delivered_at.all() else 0,
            }
        ),
    )
    return result, pictures


def _record_step(
    record: RunRecord,
    env: WarehouseFleetEnv,
    actions: dict[str, int],
    before: np.ndarray,
    headings_before: np.ndarray | None,
    busy: np.ndarray | None,
    seconds: float,
) -> None:
    """One step of ``env`` into ``record``: planned actions (WAIT for robots that are not
    live), the actions taken (from the robots' cells and headings), who had an errand."""
    cols = env.grid.cols
    planned = np.full(env.num_robots, env.action_space(env.possible_agents[0]).n - 1)
    for agent, action in actions.items():
        planned[int(agent.rsplit("_", 1)[1])] = int(action)
    after = env.robot_cells
    taken = actual_actions(before @ [cols, 1], after @ [cols, 1], cols,
                           headings_before, env.robot_headings)  # fmt: skip
    had = np.ones(env.num_robots, dtype=bool) if busy is None else busy
    record.add(planned, taken, had, seconds)


def run_baselines(
    env: WarehouseFleetEnv, *, steps: int, seed: int = 0, skip: str = ""
) -> dict[str, Simulation]:
    """The :data:`BASELINES` (but ``skip``) on ``env`` with the same seed and steps, by name."""
    runs: dict[str, Simulation] = {}
    for name in BASELINES:
        if name != skip:
            policy = make_policy(name, env, seed=seed)
            runs[name], _ = simulate(env, policy, steps=steps, seed=seed, name=name)
    return runs


def comparison_table(runs: dict[str, Simulation]) -> str:
    """:func:`~warehouse_phys.rl.fleet_evaluation.compare_policies` of ``runs`` by name: one
    line of measures each, then a ``WORSE:`` line for each run below a baseline."""
    return compare_policies({name: _Row(run) for name, run in runs.items()})


@dataclass(frozen=True)
class _Row:
    """A run as :func:`compare_policies` shows it: its measures without its name."""

    run: Simulation

    @property
    def throughput(self) -> float:
        return self.run.throughput

    def summary(self) -> str:
        return self.run.measures()


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog=PROG,
        description="Run a fleet policy on a floor; print and save its throughput.",
    )
    parser.add_argument("--layout", help="a preset, a MovingAI .map file or a layout file")
    parser.add_argument(
        "--instance", type=Path,
        help="a League of Robot Runners instance (.json): its floor, robots and tasks (one "
        "naming agentCounter or delayConfig runs on ticks)",
    )  # fmt: skip
    parser.add_argument(
        "--moves", choices=MOVE_MODELS, default="grid",
        help="grid: four directions (default); rotate: robots turn in place and drive forward",
    )  # fmt: skip
    parser.add_argument(
        "--scheduler", choices=tuple(SCHEDULERS),
        help="which free robot takes which task, on a 2024 or later instance: nearest (the "
        "first stop nearest the robot, default) or makespan (the least distance to the first "
        "stop plus the task's own length, as the competition's default entry)",
    )  # fmt: skip
    parser.add_argument("--rows", type=bounded_int(2, "at least 2 rows"), help="empty floor rows")
    parser.add_argument("--cols", type=bounded_int(2, "at least 2 columns"), help="columns")
    parser.add_argument(
        "--robots",
        type=bounded_int(1, f"a number of robots from 1 to {MAX_CLI_ROBOTS:,}", MAX_CLI_ROBOTS),
        help="robots in the fleet (default 4; an instance: its teamSize)",
    )
    parser.add_argument(
        "--policy",
        default="pibt",
        help="pibt (default), guided (PIBT following traffic-priced guide paths), shortest, "
        "random, or a table (.npz)",
    )
    parser.add_argument(
        "--steps", type=bounded_int(1, "a positive number of steps"),
        help=f"joint steps (default {DEFAULT_STEPS}; an instance: {INSTANCE_STEPS:,}); on "
        f"ticks: ticks (default: an instance's {INSTANCE_STEPS:,}, as LoRR 2026 counts; a "
        f"floor's {DEFAULT_STEPS} moves' worth)",
    )  # fmt: skip
    parser.add_argument(
        "--on-delivery", choices=DELIVERY_MODES,
        help="what a robot does with a delivered package (default new_package: lifelong)",
    )  # fmt: skip
    parser.add_argument("--physics", action="store_true", help="drive the physics twin")
    from warehouse_phys.apps.simulate_async import add_tick_arguments

    add_tick_arguments(parser)
    parser.add_argument("--seed", type=bounded_int(0, "a seed of 0 or more"), default=0)
    parser.add_argument(
        "--frames", type=bounded_int(0, "a number of frames of 0 or more"),
        default=DEFAULT_FRAMES, help=f"GIF frames (default {DEFAULT_FRAMES}; 0: no GIF)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, help="run folder to write")
    parser.add_argument(
        "--overwrite", action="store_true", help="reuse --out holding an earlier run's files"
    )
    parser.add_argument(
        "--no-compare", action="store_true",
        help=f"never run the baselines ({', '.join(BASELINES)}); they run by default when "
        f"robots x steps is at most {COMPARE_BUDGET:,} on the grid",
    )  # fmt: skip
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


@stops_on_sigterm
def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status: 0, 2 for a bad command line, 1 when
    a file cannot be written, 130 on Ctrl-C and 143 on SIGTERM (saying what was written;
    a new run folder left empty is removed)."""
    from warehouse_phys.files.runfolder import RunFolderError, RunWriteError

    folder = None
    try:
        args = build_parser().parse_args(argv)
        env, policy = _setup(args)
        label = _floor_label(args)
        name = (
            f"simulate-{label}-{env.num_robots}-{Path(args.policy).stem}-seed{args.seed}-"
            f"{time.strftime('%Y%m%d-%H%M%S')}"
        )
        new = DEFAULT_RUNS_DIR / name
        with opened_run_folder(args.out, new, RUN_FILES, overwrite=args.overwrite) as folder:
            result, frames, record = _run(args, env, policy, label)
            if record is not None:  # before the baselines run the errand list again
                instance, errands = env.instance, env.errands
                options = result.lorr_output_options()
                folder.write(
                    "lorr-output.json",
                    lambda path: write_output(path, instance, record, errands, **options),
                )
            runs = {result.policy: result}
            if _compare(args, env):
                runs |= run_baselines(env, steps=args.steps, seed=args.seed, skip=result.policy)
            _write(folder, env, result, frames, runs)
    except (UsageError, RunFolderError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except RunWriteError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as interrupt:
        stopped, status = interruption(interrupt)
        print(f"{PROG}: {stopped}; {written_note(folder)}", file=sys.stderr)
        return status
    print(result.summary())
    for note in result.not_simulated:
        print(f"not simulated: {note}")
    if len(runs) > 1:
        print("against the baselines, on the same floor, seed and steps:")
        print(comparison_table(runs))
    print(f"wrote {folder.path}/: {', '.join(folder.written)}")
    return 0


def _setup(args: argparse.Namespace) -> tuple[Any, FleetPolicy | None]:
    """The fleet and its policy that the command line asks for: the asynchronous fleet
    and no policy for a run on ticks (:mod:`warehouse_phys.apps.simulate_async`).

    Raises:
        UsageError: one line, for arguments that do not go together or that the fleet
            refuses, or an instance file that cannot be read.
    """
    from warehouse_phys.apps.simulate_async import default_ticks, tick_fleet, tick_options

    if args.layout is not None and (args.rows is not None or args.cols is not None):
        raise UsageError("give --layout or --rows/--cols, not both")
    if args.scheduler is not None and args.instance is None:
        raise UsageError("--scheduler hands out an instance's tasks: give --instance")
    instance = None
    if args.instance is not None:
        given = [flag for flag, value in (("--layout", args.layout), ("--rows", args.rows),
                 ("--cols", args.cols), ("--robots", args.robots),
                 ("--on-delivery", args.on_delivery)) if value is not None]  # fmt: skip
        if given:
            raise UsageError(f"an instance gives the floor, the robots and their errands; "
                             f"do not give {', '.join(given)}")  # fmt: skip
        try:
            instance = read_instance(args.instance)
        except (ValueError, TypeError, OSError) as error:
            raise UsageError(str(error).splitlines()[0]) from None
        floor: dict[str, Any] = {"instance": instance, "record_errands": True}
        if args.scheduler is not None and instance.assignment != SCHEDULED:
            raise UsageError(
                f"--scheduler: {instance.name} assigns its tasks {instance.assignment!r} "
                "(LoRR 2023), without a scheduler"
            )
        if args.scheduler is not None:
            floor["scheduler"] = SCHEDULERS[args.scheduler]
    elif args.layout is None:
        floor = {"grid_rows": args.rows or 4, "grid_cols": args.cols or 5}
    else:
        floor = {"layout": _fleet_layout(args.layout)}
    ticks = tick_options(args, instance)
    if args.steps is None and ticks is not None:
        args.steps = default_ticks(instance, ticks)
    elif args.steps is None:
        args.steps = DEFAULT_STEPS if instance is None else INSTANCE_STEPS
    if args.instance is None:
        floor |= {"num_robots": args.robots or 4, "on_delivery": args.on_delivery or "new_package"}
    try:
        if ticks is not None:
            return tick_fleet(floor, ticks, ticks=args.steps, physics=args.physics,
                              seed=args.seed, moves=args.moves), None  # fmt: skip
        env = parallel_env(
            physics=args.physics, max_cycles=args.steps, moves=args.moves,
            observation=_observation_of(args.policy), **floor,
        )  # fmt: skip
        policy = make_policy(args.policy, env, seed=args.seed)
    except (ValueError, TypeError, OSError) as error:
        raise UsageError(str(error).splitlines()[0]) from None
    return env, policy


def _scheduler_name(errands: Any) -> str | None:
    """The name of the scheduler that hands ``errands``' tasks out, None if none does."""
    scheduler = getattr(errands, "scheduler", None)
    if scheduler is None:
        return None
    return getattr(scheduler, "__name__", type(scheduler).__name__)


def _not_simulated(instance: Any) -> tuple[str, ...]:
    """What of a 2026 instance the lock-step fleet does not model, in words: its actions'
    ticks (``agentCounter``) and its random delays (``delayConfig``). The command runs
    such an instance on ticks (:mod:`warehouse_phys.apps.simulate_async`); a lock-step
    fleet built on one in Python gets these notes."""
    if instance is None:
        return ()
    notes = []
    if instance.agent_counter not in (None, 1):
        notes.append(f"agentCounter ({instance.agent_counter} ticks an action): here an "
                     "action takes one step")  # fmt: skip
    if instance.delay is not None:
        notes.append(f"delayConfig (pDelay {instance.delay.p_delay:g}): here no delays")
    return tuple(notes)


def _fleet_layout(name: str) -> str | tuple[str, ...]:
    """The fleet's ``layout=`` for ``--layout name``: a preset's name or a map's path as
    given (the fleet reads them), else a layout text file's rows, read as train, play and
    sweep read them.

    Raises:
        UsageError: for a name that is neither a preset nor a file, or a file that is not
            a layout.
    """
    if name in PRESETS or name in FLEET_PRESETS or name.endswith(".map"):
        return name
    rows = floor_from_layout(name).layout
    return name if rows is None else rows


def _compare(args: argparse.Namespace, env: Any) -> bool:
    """Whether the baselines run too: unless --no-compare, on the grid, in lock step, when
    cheap."""
    cheap = env.num_robots * args.steps <= COMPARE_BUDGET
    lock_step = isinstance(env, WarehouseFleetEnv)
    return not args.no_compare and not args.physics and lock_step and cheap


def _observation_of(policy: str) -> str:
    """The observation a table was trained on (its shape says), else ``"local"``."""
    if not policy.endswith(".npz"):
        return "local"
    from warehouse_phys.rl.qlearning import QTableError, load_q_table

    try:
        q, _ = load_q_table(policy)
    except (QTableError, OSError) as error:
        raise ValueError(f"--policy {error}") from None
    return "neighbours" if q.ndim == 6 else "local"


def _floor_label(args: argparse.Namespace) -> str:
    if args.instance is not None:
        return Path(args.instance).stem
    if args.layout is None:
        return f"{args.rows or 4}x{args.cols or 5}"
    return Path(args.layout).stem  # a preset's name, a map's or a layout file's stem


def _run(
    args: argparse.Namespace, env: Any, policy: FleetPolicy | None, label: str
) -> tuple[Simulation, list[np.ndarray], RunRecord | None]:
    """Run ``policy`` on ``env`` (a run on ticks: no policy) as the command line says,
    with a progress bar; returns the measures, the frames and an instance's record."""
    from tqdm import tqdm

    if policy is None:  # on ticks
        from warehouse_phys.apps.simulate_async import simulate_ticks

        play, turning, unit = functools.partial(simulate_ticks, env), env.turning, "tick"
    else:
        play, turning, unit = functools.partial(simulate, env, policy), env.turning, "step"
    record = None if env.instance is None else RunRecord(env.num_robots, turning=turning)
    # The floor's and the fleet's long-lived objects (tens of thousands of cells on a large
    # map) leave Python's full collections, which otherwise walk them and stall a step.
    gc.freeze()
    # disable=None: tqdm switches itself off when stderr is not a terminal.
    with tqdm(total=args.steps, desc="simulating", unit=unit,
              disable=True if args.quiet else None) as bar:  # fmt: skip
        try:
            result, frames = play(
                steps=args.steps, seed=args.seed, frames=args.frames, on_step=bar.update,
                name=Path(args.policy).name, layout=label, record=record,
            )  # fmt: skip
        except ValueError as error:  # a table's observation that does not fit, ...
            raise UsageError(str(error).splitlines()[0]) from None
        finally:
            gc.unfreeze()
    return result, frames, record


def _write(
    folder: Any,
    env: Any,
    result: Simulation,
    frames: list,
    runs: dict[str, Simulation],
) -> None:
    from warehouse_phys.drawing.animation import Animation
    from warehouse_phys.files.atomic import atomic_write_text
    from warehouse_phys.viz.plots import congestion_figure, save_figure, throughput_figure

    summary = result.to_json()
    if len(runs) > 1:
        keys = ("throughput", "deliveries", "waits", "refused")
        summary["comparison"] = {
            name: {key: run.to_json()[key] for key in keys} for name, run in runs.items()
        }
        worse = worse_policies(runs)
        summary["worse_than"] = [{"policy": name, "reference": ref} for name, ref in worse]
    text = json.dumps(summary, indent=2) + "\n"
    folder.write("summary.json", lambda path: atomic_write_text(path, text))
    folder.write(
        "throughput.png",
        lambda path: save_figure(
            throughput_figure(result.deliveries, result.summary(), **result.figure_options()), path
        ),
    )
    folder.write(
        "congestion.png", lambda path: save_figure(congestion_figure(env.grid, result.waits), path)
    )
    if frames:
        folder.write("fleet.gif", lambda path: Animation(frames, fps=8).save(path))


if __name__ == "__main__":
    sys.exit(main())
