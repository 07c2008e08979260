"""``simulate`` on ticks: League of Robot Runners 2026's ``agentCounter`` and ``delayConfig``.

``python -m warehouse_phys.simulate`` runs the asynchronous fleet
(:class:`~warehouse_phys.envs.async_fleet.AsyncFleetEnv`) instead of the lock-step one
when the instance names ``agentCounter`` or ``delayConfig`` (LoRR 2026), or when the
command line gives ``--ticks-per-move`` or ``--p-delay`` (on any instance or floor). PIBT
plans a move for every robot each move-duration; a move takes ``ticks_per_move`` ticks;
delays are drawn each tick as LoRR 2026 draws them
(:class:`~warehouse_phys.execution.delays.DelayGenerator`); the executor says GO or STOP to
each robot each tick so that no two robots ever meet, whatever the delays
(:mod:`warehouse_phys.execution.runner`). The command tells every robot GO every tick: the
executor alone holds robots back. ``--physics`` drives the physics twin's bodies.

The flags (:func:`add_tick_arguments`):

- ``--ticks-per-move N``: the ticks a move takes (default: the instance's
  ``agentCounter``, else LoRR's 10);
- ``--p-delay P``: the chance a tick that a robot not yet delayed is delayed (LoRR's
  ``pDelay``). On an instance with a ``delayConfig`` it replaces ``pDelay`` alone;
  elsewhere the rest of the configuration is :data:`DEFAULT_DELAYS`: bernoulli events,
  durations uniform over 1-20 ticks, seed 0 (LoRR's own defaults but ``maxDelay``, 1
  there, 20 as in the issue's figures);
- ``--delay-seed S``: the delays' seed (default: the ``delayConfig``'s, else 0); it
  needs delays to seed.

Four-direction robots (``--moves grid``, a floor's default) and LoRR's turning robots
(``--moves rotate``, an instance's default: a forward move or a quarter turn each takes
``agentCounter`` ticks) run on ticks, planned by ``--policy pibt`` or ``guided`` (PIBT
windows, :func:`~warehouse_phys.execution.windows.pibt_window`); other policies and
one-shot ``--on-delivery`` are refused in one line (the executor runs a planner's lifelong
plans). Robots here are discs kept ``min_gap`` apart (our model); an instance run with
turning robots and without ``--physics`` runs by the start kit's rules instead, its
robots squares (:mod:`warehouse_phys.apps.simulate.on_kit`).

``--steps`` counts **ticks** in such a run: 5,000 by default on an instance, as LoRR
2026 counts its ``simulationTime`` (execution ticks, its output's ``makespan``); on a
floor :data:`DEFAULT_MOVES` moves' worth (``256 x ticks_per_move`` ticks), the simulated
time of a lock-step run's default. The run reports errands (deliveries on a floor) and
tasks a tick and a move-duration, the shares of robot-ticks stood still by a robot's own
delay and by knock-on delay (a robot ahead had not moved on), the mean drift from the
plan (:meth:`~warehouse_phys.execution.runner.ExecutionMeasures.shares`), and on an
instance writes ``lorr-output.json`` with ``agentMaxCounter`` and ``delayIntervals``
(:mod:`warehouse_phys.lorr.output`).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from warehouse_phys.apps.cli import UsageError, bounded_int
from warehouse_phys.apps.simulate.results import DEFAULT_STEPS, INSTANCE_STEPS, Simulation
from warehouse_phys.execution.delays import MAX_SEED, DelayConfig
from warehouse_phys.execution.ticks import LORR_TICKS_PER_MOVE, MAX_TICKS_PER_MOVE
from warehouse_phys.execution.windows import WINDOW_PLANNERS
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.output import RunRecord, actual_actions
from warehouse_phys.planners.named import TURNING_ONLY

if TYPE_CHECKING:
    from warehouse_phys.envs.async_fleet import AsyncFleetEnv

#: The delays ``--p-delay`` draws where no ``delayConfig`` gives the rest: LoRR's
#: ``DelayConfig`` defaults (seed 0, bernoulli, uniform) with durations of 1-20 ticks.
DEFAULT_DELAYS = DelayConfig(seed=0, min_delay=1, max_delay=20, event_model="bernoulli",
                             p_delay=0.0, duration_model="uniform")  # fmt: skip
#: A floor's run on ticks lasts this many moves' worth of ticks by default (the lock-step
#: default's steps).
DEFAULT_MOVES = DEFAULT_STEPS


def add_tick_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--ticks-per-move``, ``--p-delay`` and ``--delay-seed`` (see the module)."""
    parser.add_argument(
        "--ticks-per-move", metavar="N",
        type=bounded_int(1, f"ticks a move takes, 1 to {MAX_TICKS_PER_MOVE:,}", MAX_TICKS_PER_MOVE),
        help="run on ticks: a move takes N ticks (default: an instance's agentCounter, else "
        f"{LORR_TICKS_PER_MOVE})",
    )  # fmt: skip
    parser.add_argument(
        "--p-delay", metavar="P", type=_chance,
        help="run on ticks with delays: each tick a robot is delayed with chance P (an "
        "instance's delayConfig gives the rest, else bernoulli, 1-20 ticks uniform)",
    )  # fmt: skip
    parser.add_argument(
        "--delay-seed", metavar="S",
        type=bounded_int(0, f"a seed from 0 to {MAX_SEED:,}", MAX_SEED),
        help="seed of the delays (default: the delayConfig's, else 0)",
    )  # fmt: skip


def _chance(text: str) -> float:
    """An argument type: a chance from 0 to 1."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a chance from 0 to 1, got {text!r}") from None
    if not 0 <= value <= 1:  # NaN fails too
        raise argparse.ArgumentTypeError(f"expected a chance from 0 to 1, got {text}")
    return value


@dataclass(frozen=True)
class TickOptions:
    """How a run on ticks runs: the ticks a move takes and its delays."""

    ticks_per_move: int
    #: The delays, ``None`` for none.
    delays: DelayConfig | None

    def describe(self) -> str:
        """The options in words: ``3 ticks a move, pDelay 0.01 (bernoulli), delays of 1-4
        ticks (uniform), seed 0``."""
        line = f"{self.ticks_per_move} tick{'s' if self.ticks_per_move > 1 else ''} a move"
        config = self.delays
        if config is None:
            return f"{line}, no delays"
        return (
            f"{line}, pDelay {config.p_delay:g} ({config.event_model}), delays of "
            f"{config.min_delay}-{config.max_delay} ticks ({config.duration_model}), "
            f"seed {config.seed}"
        )


def tick_options(args: argparse.Namespace, instance: LorrInstance | None) -> TickOptions | None:
    """The run on ticks that the command line and the instance ask for, or ``None`` for a
    lock-step run (no ``agentCounter``, no ``delayConfig``, no tick flag).

    Raises:
        UsageError: one line, for ticks with a policy that is not a planner of the
            windows (:data:`~warehouse_phys.execution.windows.WINDOW_PLANNERS`, every
            planner by name; those of turning robots only with ``--moves rotate``) or a
            one-shot ``--on-delivery``, or ``--delay-seed`` with no delays.
    """
    counter = None if instance is None else instance.agent_counter
    config = None if instance is None else instance.delay
    flags = [name for name, value in (("--ticks-per-move", args.ticks_per_move),
             ("--p-delay", args.p_delay)) if value is not None]  # fmt: skip
    if not flags and counter is None and config is None:
        if args.delay_seed is not None:
            raise UsageError("--delay-seed needs delays: give --p-delay too")
        return None
    named = [key for key, value in (("agentCounter", counter), ("delayConfig", config))
             if value is not None]  # fmt: skip
    why = f"{' and '.join(flags)} given" if flags else f"{instance.name} has {' and '.join(named)}"
    if args.policy not in WINDOW_PLANNERS:
        raise UsageError(
            f"--policy {args.policy}: a run on ticks ({why}) executes the plans of a "
            f"planner ({', '.join(WINDOW_PLANNERS)}); other policies run in lock step"
        )
    if args.policy in TURNING_ONLY and args.moves != "rotate":
        raise UsageError(f"--policy {args.policy} plans turning robots only: give --moves "
                         "rotate")  # fmt: skip
    if args.on_delivery not in (None, "new_package"):
        raise UsageError(f"--on-delivery {args.on_delivery}: a run on ticks ({why}) is "
                         "lifelong (new_package)")  # fmt: skip
    if args.p_delay is not None:
        config = dataclasses.replace(config or DEFAULT_DELAYS, p_delay=args.p_delay)
    if args.delay_seed is not None:
        if config is None:
            raise UsageError("--delay-seed needs delays: give --p-delay too")
        config = dataclasses.replace(config, seed=args.delay_seed)
    return TickOptions(args.ticks_per_move or counter or LORR_TICKS_PER_MOVE, config)


def default_ticks(instance: LorrInstance | None, options: TickOptions) -> int:
    """``--steps`` of a run on ticks when not given: an instance's 5,000 ticks (LoRR
    2026's ``simulationTime``), a floor's :data:`DEFAULT_MOVES` moves' worth."""
    return INSTANCE_STEPS if instance is not None else DEFAULT_MOVES * options.ticks_per_move


def tick_fleet(
    floor: dict[str, Any], options: TickOptions, *, ticks: int, physics: bool, seed: int,
    moves: str = "grid", physics_threads: int = 1, planner: str = "pibt",
    guidance: dict[str, Any] | None = None,
) -> AsyncFleetEnv:  # fmt: skip
    """The asynchronous fleet on ``floor`` (the lock-step fleet's floor keywords:
    ``instance`` and ``record_errands``, or ``layout``/``grid_rows``/``grid_cols`` and
    ``num_robots``; ``on_delivery`` is dropped) for ``ticks`` ticks, its windows planned
    by ``planner`` (:data:`~warehouse_phys.execution.windows.WINDOW_PLANNERS`) with the
    fields ``guidance``.

    Raises:
        ValueError, TypeError: as the environment refuses its arguments.
    """
    from warehouse_phys.envs.async_fleet import parallel_env

    kwargs = {key: value for key, value in floor.items() if key != "on_delivery"}
    return parallel_env(ticks_per_move=options.ticks_per_move, delays=options.delays,
                        max_cycles=ticks, physics=physics, seed=seed, moves=moves,
                        planner=planner, guidance=guidance,
                        **({"physics_threads": physics_threads} if physics else {}),
                        **kwargs)  # fmt: skip


@dataclass(frozen=True)
class TickSimulation(Simulation):
    """What a fleet did in a run on ticks: each entry of ``deliveries``, ``tasks`` and
    ``step_seconds`` is a tick, ``steps`` counts ticks, ``throughput`` is deliveries
    (errands) a tick; ``waits`` counts robot-ticks a robot away from its goal stood still
    on a cell (a planned wait, its own delay or a knock-on delay)."""

    ticks_per_move: int = 1
    delays: DelayConfig | None = None
    #: :meth:`~warehouse_phys.execution.runner.ExecutionMeasures.shares` at the end.
    shares: dict[str, float] = dataclasses.field(default_factory=dict)
    #: Windows PIBT planned.
    plans: int = 0
    #: The executor's closest approach of two robots' centres [cells].
    min_gap: float = 0.0
    #: LoRR's ``delayIntervals``: per robot its ``[start, end]`` ticks; ``None``: no delays.
    delay_intervals: list[list[list[int]]] | None = None
    #: Physics: the largest snap at a move's end [cells].
    max_snap_error: float = 0.0

    @property
    def options(self) -> TickOptions:
        return TickOptions(self.ticks_per_move, self.delays)

    @property
    def delays_drawn(self) -> int:
        """Delays drawn over the run, every robot's."""
        return sum(map(len, self.delay_intervals or []))

    def totals(self) -> dict[str, int]:
        """Deliveries (``errands`` on an instance) and ``tasks`` over the run, by name."""
        totals = {"deliveries" if self.tasks is None else "errands": int(self.deliveries.sum())}
        if self.tasks is not None:
            totals["tasks"] = int(self.tasks.sum())
        return totals

    def rates(self) -> dict[str, float]:
        """:meth:`totals` a tick (``<name>_per_tick``) and a move-duration (``_per_move``)."""
        ticks = max(self.steps, 1)
        rates = {}
        for name, total in self.totals().items():
            rates[f"{name}_per_tick"] = total / ticks
            rates[f"{name}_per_move"] = total / ticks * self.ticks_per_move
        return rates

    def measures(self) -> str:
        """The measures in one line: deliveries or errands and tasks a tick and a
        move-duration, the shares of robot-ticks stood still by own and knock-on
        delays, the mean drift, the delays drawn."""
        totals, rates = self.totals(), self.rates()
        parts = [f"{rates[f'{name}_per_tick']:.3f} {name}/tick = "
                 f"{rates[f'{name}_per_move']:.2f} a move" for name in totals]  # fmt: skip
        counts = [f"{total:,} {name}" for name, total in totals.items()]
        shares = self.shares
        return (
            f"{', '.join(parts)} ({', '.join(counts)}); robot-ticks stood still: "
            f"{shares.get('own_delay_share', 0.0):.2%} own delay, "
            f"{shares.get('knock_on_share', 0.0):.2%} knock-on; mean drift "
            f"{shares.get('mean_drift_ticks', 0.0):.3f} ticks; {self.delays_drawn:,} delays drawn"
        )

    def summary(self) -> str:
        twin = "physics twin, " if self.physics else ""
        return (
            f"{self.policy}, {self.robots:,} robots on {self.layout}, {self.steps:,} ticks "
            f"({twin}{self.options.describe()}, {self.moves} moves): {self.measures()}"
        )

    def to_json(self) -> dict[str, Any]:
        """The lock-step summary's keys, every per-step one counting ticks
        (``time_unit``), with the ticks' own: ``ticks``, ``ticks_per_move``,
        ``delay_config``, ``delays_drawn``, the rates a tick and a move-duration, and
        ``execution`` (the shares, the mean drift, the plans, ``min_gap``)."""
        data = super().to_json()
        series = {key: data.pop(key) for key in ("deliveries_per_step", "tasks_per_step_series")
                  if key in data}  # fmt: skip
        data.pop("errands_per_step", None)
        data.pop("tasks_per_step", None)
        data |= {
            "time_unit": "tick",
            "ticks": self.steps,
            "ticks_per_move": self.ticks_per_move,
            "delay_config": None if self.delays is None else self.delays.to_json(),
            "delays_drawn": self.delays_drawn,
            **self.rates(),
            "execution": {**self.shares, "plans": self.plans, "min_gap": self.min_gap},
        }
        if self.physics:
            data["max_snap_error"] = self.max_snap_error
        return data | series

    def lorr_output_options(self) -> dict[str, Any]:
        return {"agent_max_counter": self.ticks_per_move, "delay_intervals": self.delay_intervals}

    def figure_options(self) -> dict[str, Any]:
        # The rolling mean over 32 moves' worth of ticks, as a lock-step run's over 32 steps.
        return {"unit": "tick", "window": 32 * self.ticks_per_move}


def tick_notes(instance: LorrInstance | None, min_gap: float, turning: bool) -> tuple[str, ...]:
    """What of LoRR 2026's model a run on ticks of ``instance`` does not model, in words:
    its turning robots (unless ``turning``), and its square robots' overlap check
    (``agentSize``)."""
    if instance is None:
        return ()
    size = 1.0 if instance.agent_size is None else instance.agent_size
    notes = () if turning else (
        "turning robots (LoRR's robots turn, a turn taking agentCounter ticks): here robots "
        "move in four directions (--moves rotate turns them)",
    )  # fmt: skip
    return (*notes,
            f"agentSize ({size:g}: LoRR's square robots must not overlap): here robots are "
            f"points kept {min_gap:.3g} cells apart, so one may round a corner right behind "
            "another")  # fmt: skip


def simulate_ticks(
    env: AsyncFleetEnv,
    *,
    steps: int,
    seed: int = 0,
    frames: int = 0,
    on_step: Callable[[], Any] | None = None,
    name: str = "pibt",
    layout: str = "",
    cell_px: int | None = None,
    record: RunRecord | None = None,
) -> tuple[TickSimulation, list[np.ndarray]]:
    """Run ``env`` from ``env.reset(seed=seed)`` for ``steps`` ticks (fewer if it ends),
    every robot told GO every tick; returns the measures and ``min(frames, steps + 1)``
    map frames evenly spread (robots on the cell they are on or leave, their goals as
    packages), the first at the reset.

    ``on_step()`` is called after each tick; ``record`` gets each tick's actual actions (a
    move's letter on the tick it ends, a wait otherwise; the planned ones are the same),
    who had an errand, and the tick's CPU time where PIBT planned (else none).
    """
    from warehouse_phys.envs.async_fleet import GO

    begun = time.process_time()
    observations, _ = env.reset_arrays(seed=seed)  # arrays: no dict a robot a tick
    reset_seconds = time.process_time() - begun
    grid, errands = env.grid, env.errands
    cols = grid.cols
    go = np.full(env.num_robots, GO, dtype=np.int64)
    waits = np.zeros(grid.rows * cols, dtype=np.int64)
    deliveries, tasks_at, step_seconds, snaps = [], [], [], [0.0]
    camera = _Camera(grid, frames, steps, cell_px)
    camera.shoot(0, env, observations)
    for tick in range(steps):
        if not env.agents:
            break
        execution = env.execution
        executor = execution.executor
        left, done = executor.left.copy(), executor.done.copy()
        faced = None if executor.headings is None else executor.headings.copy()
        goals = _goal_cells(observations, cols)
        busy = np.ones(env.num_robots, dtype=bool) if errands is None else errands.goals >= 0
        errands_before, plans_before = env.errands_done, execution.measures.plans
        tasks_before = 0 if errands is None else errands.tasks_done
        begun = time.process_time()
        observations, _, _, _, infos = env.step_arrays(go)
        step_seconds.append(time.process_time() - begun)
        deliveries.append(env.errands_done - errands_before)
        if errands is not None:
            tasks_at.append(errands.tasks_done - tasks_before)
        stood = (executor.left == left) & (executor.done == done) & (goals != left)
        np.add.at(waits, left[stood], 1)
        if record is not None:
            taken = actual_actions(left, executor.left, cols, faced, executor.headings)
            planned = execution.measures.plans > plans_before
            record.add(taken, taken, busy, step_seconds[-1] if planned else None)
        if env.physics is not None:
            snaps.append(float(infos["snap_error"].max(initial=0.0)))
        camera.shoot(tick + 1, env, observations)
        if on_step is not None:
            on_step()
    execution = env.execution
    return TickSimulation(
        layout=layout or f"{grid.rows}x{grid.cols}", robots=env.num_robots, policy=name,
        seed=seed, on_delivery="new_package", physics=env.physics is not None,
        deliveries=np.array(deliveries, dtype=np.int64), waits=waits.reshape(grid.rows, cols),
        refused=0, cpu_seconds=float(sum(step_seconds)), reset_seconds=reset_seconds,
        step_seconds=np.array(step_seconds), frame_seconds=np.array(camera.seconds),
        moves=env.moves, instance=None if env.instance is None else env.instance.name,
        not_simulated=tick_notes(env.instance, env.min_gap, env.turning),
        tasks=None if errands is None else np.array(tasks_at, dtype=np.int64),
        ticks_per_move=execution.ticks_per_move, delays=env.delays,
        shares=execution.measures.shares(), plans=execution.measures.plans,
        min_gap=float(env.min_gap), max_snap_error=float(max(snaps)),
        safety=None if env.safety is None else env.safety.summary(),
        delay_intervals=None if execution.delays is None else execution.delays.intervals_json(),
    ), camera.pictures  # fmt: skip


def _goal_cells(observations: np.ndarray | dict[str, np.ndarray], cols: int) -> np.ndarray:
    """``(N,)`` each robot's goal cell index, from its observation (goal row and column
    follow its own cell's), in array form or PettingZoo's dict."""
    if isinstance(observations, dict):
        observations = list(observations.values())
    table = np.asarray(observations, dtype=np.int64)
    return table[:, 2] * cols + table[:, 3]


class _Camera:
    """The frames of a run: ``frames`` of them after ticks evenly spread over ``steps``
    (0: at the reset), each timed."""

    def __init__(self, grid: Any, frames: int, steps: int, cell_px: int | None) -> None:
        self.grid, self.cell_px = grid, cell_px
        shots = np.linspace(0, steps, min(frames, steps + 1)).round().astype(int)
        self.shots = set(np.unique(shots).tolist()) if frames else set()
        self.pictures: list[np.ndarray] = []
        self.seconds: list[float] = []

    def shoot(self, tick: int, env: AsyncFleetEnv, observations: np.ndarray) -> None:
        """Draw the floor after ``tick`` ticks if it is one of the shots."""
        if tick not in self.shots or not len(observations):
            return
        from warehouse_phys.drawing.map_frames import fleet_map_frame

        begun = time.process_time()
        cols = self.grid.cols
        robots = np.stack(np.divmod(env.execution.executor.left, cols), axis=1)
        goals = np.stack(np.divmod(_goal_cells(observations, cols), cols), axis=1)
        self.pictures.append(fleet_map_frame(self.grid, robots, goals, cell_px=self.cell_px))
        self.seconds.append(time.process_time() - begun)
