"""``simulate`` by the start kit's rules: a League of Robot Runners instance run as the kit
runs the package's entry.

An instance run on ticks (one naming ``agentCounter`` or ``delayConfig``, or given
``--ticks-per-move`` / ``--p-delay``) with the competition's turning robots (``--moves``
follows the instance: ``rotate``) and without ``--physics`` runs
:class:`~warehouse_phys.lorr.startkit.system.KitSystem`: the kit's loop (a plan and a
schedule every round of ``planCommTimeLimit``, made from where the robots will stand, the
executor's GO or STOP every tick before the tick's delays) with the entry's planner
(``--policy``: the entry's ``guided-ops-repair``, ``guided`` or ``pibt``, set as in the
entry, or any other planner by name), scheduler (``--scheduler``; by default, and as
``rematch``, the entry's: the minimum-cost assignment on true distances, pairing again
the robots on their way to a task not opened yet; ``rematch-capped``: the same with a cap
on each station's queue, the entry's ``assignment-capped``; ``rematch-backlog``, that
cap growing with a station's open tasks, the entry's ``assignment-backlog``) and executor, robots
as squares of side ``agentSize`` (the kit's swept-square rule, checked every tick). It
writes the kit's 2026 output file (:mod:`warehouse_phys.lorr.output_2026`) as
``lorr-output.json``.

``--delays-from OUTPUT.json`` replays the ``delayIntervals`` of a kit run (its output
file) instead of drawing delays (:class:`~warehouse_phys.execution.delay_replay.DelayReplay`):
the same delays as the kit's run, so that its executor and ours, or the kit's run and this
one, can be set side by side. The physics twin (``--physics``) and four-direction robots
(``--moves grid``) run the asynchronous fleet instead
(:mod:`warehouse_phys.apps.simulate.on_ticks`), robots as discs: our model, not the kit's.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from warehouse_phys.apps.cli import UsageError
from warehouse_phys.apps.simulate.results import Simulation
from warehouse_phys.execution.delay_replay import DelayReplay
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.output_2026 import delay_intervals, write_output
from warehouse_phys.lorr.startkit.scheduler import FLEET_SCHEDULERS
from warehouse_phys.lorr.startkit.system import KitSystem
from warehouse_phys.planners.named import PLANNERS

if TYPE_CHECKING:
    from warehouse_phys.lorr.output import RunRecord

#: The entry's scheduler of each fleet scheduler it plays (the entry's default for none).
_ENTRY_SCHEDULER = {fleet: entry for entry, fleet in FLEET_SCHEDULERS.items()}
_ENTRY_SCHEDULER[None] = "assignment"


def add_kit_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--delays-from`` (see the module)."""
    parser.add_argument(
        "--delays-from", metavar="OUTPUT.json", type=Path,
        help="replay the delayIntervals of a start-kit run's output file (an instance run by "
        "the kit's rules)",
    )  # fmt: skip


def kit_rules(instance: LorrInstance | None, on_ticks: bool, moves: str, physics: bool) -> bool:
    """Whether a run is by the kit's rules: an instance, on ticks, turning robots, no
    physics twin."""
    return instance is not None and on_ticks and moves == "rotate" and not physics


def kit_system(
    instance: LorrInstance, options: Any, *, policy: str, scheduler: str | None, seed: int,
    delays_from: Path | None, ticks: int, guidance: Mapping[str, Any] | None = None,
) -> KitSystem:  # fmt: skip
    """The kit's loop on ``instance`` with the ticks and delays of ``options`` (a
    :class:`~warehouse_phys.apps.simulate.on_ticks.TickOptions`), or the delays of the kit
    run ``delays_from``; ``guidance`` sets fields of the entry's planner.

    Raises:
        UsageError: one line, for a policy the entry has no planner of, a 2023 instance,
            the scheduler ``assignment`` (the entry's pairs again: ``rematch``), or a
            ``--delays-from`` file that is not a kit run's output for this instance and
            these ticks.
    """
    if policy not in PLANNERS:
        raise UsageError(f"--policy {policy}: a run by the start kit's rules plans with a "
                         f"planner: {', '.join(PLANNERS)}")  # fmt: skip
    if instance.year < 2024:
        raise UsageError(f"{instance.name} is a 2023 instance: the start kit's rules schedule "
                         "tasks (2024 and later); use --moves grid or a lock-step run")  # fmt: skip
    if scheduler == "assignment":
        raise UsageError("--scheduler assignment: by the start kit's rules the entry's "
                         "assignment pairs again; use rematch (the default), nearest or "
                         "makespan")  # fmt: skip
    delays: DelayConfig | DelayReplay | None = options.delays
    if delays_from is not None:
        delays = replayed_delays(delays_from, instance, ticks)
    try:
        return KitSystem(
            instance,
            planner=policy,
            guidance=guidance,
            scheduler=_ENTRY_SCHEDULER[scheduler],
            ticks_per_move=options.ticks_per_move,
            delays=delays,
            seed=seed,
        )
    except (ValueError, TypeError) as error:
        raise UsageError(str(error).splitlines()[0]) from None


def replayed_delays(path: Path, instance: LorrInstance, ticks: int) -> DelayReplay:
    """The delays of the kit run whose output file is ``path``, for ``ticks`` ticks of
    ``instance``.

    Raises:
        UsageError: one line naming the file, for one that cannot be read, is not an
            output file, has another team size, or covers fewer ticks.
    """
    try:
        data = json.loads(Path(path).read_bytes())
        if not isinstance(data, dict):
            raise ValueError("not a JSON object")
        intervals = delay_intervals(data, str(path))
    except (OSError, ValueError) as error:
        raise UsageError(f"--delays-from {path}: {str(error).splitlines()[0]}") from None
    if len(intervals) != instance.team_size:
        raise UsageError(f"--delays-from {path}: {len(intervals):,} robots, {instance.name} has "
                         f"{instance.team_size:,}")  # fmt: skip
    recorded = data.get("makespan")
    if not isinstance(recorded, int) or recorded < ticks:
        raise UsageError(f"--delays-from {path}: it covers {recorded} ticks, --steps asks for "
                         f"{ticks:,}")  # fmt: skip
    return DelayReplay(intervals, recorded, source=str(path))


@dataclass(frozen=True)
class KitSimulation(Simulation):
    """What a run by the kit's rules did: each entry of ``deliveries`` (errands), ``tasks``
    and ``step_seconds`` is a tick; ``waits`` counts robot-ticks a robot with an errand
    stood still on a cell."""

    ticks_per_move: int = 1
    delays: DelayConfig | None = None
    delays_from: str | None = None
    agent_size: float = 1.0
    round_ticks: int = 10
    #: Pairs of robots whose squares collided by the kit's rule (the executor allows none).
    collisions: int = 0
    schedule_errors: int = 0
    delay_intervals: list[list[list[int]]] | None = None

    def measures(self) -> str:
        ticks = max(self.steps, 1)
        errands, tasks = int(self.deliveries.sum()), int(self.tasks.sum())
        drawn = sum(map(len, self.delay_intervals or []))
        return (
            f"{errands / ticks:.3f} errands/tick = {errands / ticks * self.ticks_per_move:.2f} a "
            f"move, {tasks / ticks:.3f} tasks/tick = {tasks / ticks * self.ticks_per_move:.2f} "
            f"a move ({errands:,} errands, {tasks:,} tasks); {self.collisions:,} square "
            f"collisions by the kit's rule, {self.schedule_errors:,} schedule errors; "
            f"{drawn:,} delays"
        )

    def summary(self) -> str:
        if self.delays_from is not None:
            delays = f"the delays of {self.delays_from}"
        elif self.delays is None:
            delays = "no delays"
        else:
            config = self.delays
            delays = (f"pDelay {config.p_delay:g} ({config.event_model}), delays of "
                      f"{config.min_delay}-{config.max_delay} ticks ({config.duration_model}), "
                      f"seed {config.seed}")  # fmt: skip
        return (
            f"{self.policy}, {self.robots:,} robots on {self.layout}, {self.steps:,} ticks by "
            f"the start kit's rules ({self.ticks_per_move} ticks a move or turn, squares of "
            f"side {self.agent_size:g}, a plan every {self.round_ticks} ticks, {delays}): "
            f"{self.measures()}"
        )

    def to_json(self) -> dict[str, Any]:
        data = super().to_json()
        series = data.pop("deliveries_per_step", None)
        for key in ("errands_per_step", "tasks_per_step", "throughput"):
            data.pop(key, None)
        ticks = max(self.steps, 1)
        errands, tasks = int(self.deliveries.sum()), int(self.tasks.sum())
        data |= {
            "time_unit": "tick", "rules": "start kit", "ticks": self.steps,
            "ticks_per_move": self.ticks_per_move, "agent_size": self.agent_size,
            "round_ticks": self.round_ticks,
            "delay_config": None if self.delays is None else self.delays.to_json(),
            "delays_from": self.delays_from,
            "delays_drawn": sum(map(len, self.delay_intervals or [])),
            "errands_per_tick": errands / ticks, "tasks_per_tick": tasks / ticks,
            "square_collisions": self.collisions, "schedule_errors": self.schedule_errors,
        }  # fmt: skip
        return data | {"errands_per_tick_series": series}

    def figure_options(self) -> dict[str, Any]:
        return {"unit": "tick", "window": 32 * self.ticks_per_move}


def simulate_kit(
    system: KitSystem,
    *,
    steps: int,
    seed: int = 0,
    frames: int = 0,
    on_step: Callable[[], Any] | None = None,
    name: str = "guided",
    layout: str = "",
    record: RunRecord | None = None,
) -> tuple[KitSimulation, list[np.ndarray]]:
    """Run ``system`` from its reset for ``steps`` ticks; returns the measures and up to
    ``frames`` map frames evenly spread (the first at the reset). ``record`` is unused:
    the system keeps its own output (:meth:`KitSystem.output`)."""
    del record
    begun = time.process_time()
    system.reset()
    reset_seconds = time.process_time() - begun
    grid = system.instance.grid
    cols = grid.cols
    waits = np.zeros(grid.rows * cols, dtype=np.int64)
    errands, tasks, seconds, pictures, frame_seconds = [], [], [], [], []
    shots = set(np.linspace(0, steps, min(frames, steps + 1)).round().astype(int).tolist())
    shots = shots if frames else set()
    _shoot(system, 0, shots, pictures, frame_seconds)
    for tick in range(steps):
        executor = system.executor.executor
        left, done = executor.left.copy(), executor.done.copy()
        busy = system.tasks.goals >= 0
        begun = time.process_time()
        outcome = system.step()
        seconds.append(time.process_time() - begun)
        errands.append(outcome.errands)
        tasks.append(outcome.tasks)
        stood = busy & (executor.left == left) & (executor.done == done)
        np.add.at(waits, left[stood], 1)
        _shoot(system, tick + 1, shots, pictures, frame_seconds)
        if on_step is not None:
            on_step()
    config = system.delay_config
    return KitSimulation(
        layout=layout or system.instance.name, robots=system.instance.team_size, policy=name,
        seed=seed, on_delivery="new_package", physics=False,
        deliveries=np.array(errands, dtype=np.int64), waits=waits.reshape(grid.rows, cols),
        refused=0, cpu_seconds=float(sum(seconds)), reset_seconds=reset_seconds,
        step_seconds=np.array(seconds), frame_seconds=np.array(frame_seconds), moves="rotate",
        instance=system.instance.name, tasks=np.array(tasks, dtype=np.int64),
        scheduler=system.scheduler.name, ticks_per_move=system.ticks_per_move,
        delays=config if isinstance(config, DelayConfig) else None,
        delays_from=config.source if isinstance(config, DelayReplay) else None,
        agent_size=system.agent_size, round_ticks=system.round_ticks,
        collisions=len(system.collisions), schedule_errors=len(system.tasks.schedule_errors),
        delay_intervals=None if system.delays is None else system.delays.intervals_json(),
        not_simulated=("time: the kit runs in real time, and a late plan or command shifts "
                       "its rounds or adds ticks; here every plan is on time",),
    ), pictures  # fmt: skip


def write_kit_output(folder: Any, system: KitSystem) -> None:
    """Write ``lorr-output.json`` into ``folder`` (a run folder): the kit's 2026 output file
    of the run."""
    folder.write("lorr-output.json", lambda path: write_output(path, system.output()))


def _shoot(system: KitSystem, tick: int, shots: set[int], pictures: list, seconds: list) -> None:
    """Draw the floor after ``tick`` ticks if it is one of the shots."""
    if tick not in shots:
        return
    from warehouse_phys.drawing.map_frames import fleet_map_frame

    begun = time.process_time()
    grid, cols = system.instance.grid, system.instance.grid.cols
    executor = system.executor.executor
    goals = np.where(system.tasks.goals >= 0, system.tasks.goals, executor.left)
    robots = np.stack(np.divmod(executor.left, cols), axis=1)
    targets = np.stack(np.divmod(goals, cols), axis=1)
    pictures.append(fleet_map_frame(grid, robots, targets))
    seconds.append(time.process_time() - begun)
