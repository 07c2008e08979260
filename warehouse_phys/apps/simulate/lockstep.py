"""``simulate`` in lock step: a fleet policy moves every robot at once, a joint step at a time.

:func:`simulate` plays a policy (:func:`~warehouse_phys.apps.simulate.results.make_policy`)
on the lock-step fleet (:class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`) and
measures it into a :class:`~warehouse_phys.apps.simulate.results.Simulation`: deliveries
a step, waits on each cell, refused moves, one-shot makespans and sums of costs, an
instance's tasks, and each step's planned and actual actions for the competition's
output file. :func:`run_baselines` runs the shortest-path and random baselines on the
same floor, seed and steps when that is cheap (:data:`COMPARE_BUDGET`), and
:func:`comparison_table` sets the runs side by side.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from warehouse_phys.apps.simulate.results import Simulation, make_policy
from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.lorr.output import RunRecord, actual_actions
from warehouse_phys.rl.fleet_evaluation import FleetPolicy, compare_policies, walled_off_packages

#: The baselines a run is compared with, when that is cheap.
BASELINES = ("shortest", "random")
#: Robot-steps (robots x steps) up to which the command also runs the baselines: a few
#: seconds on the grid; the physics world is never compared.
COMPARE_BUDGET = 200_000


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
    from warehouse_phys.drawing.map_frames import fleet_map_frame

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
        physics=env.physics is not None,
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
        safety=None if getattr(env, "safety", None) is None else env.safety.summary(),
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


def _scheduler_name(errands: Any) -> str | None:
    """The name of the scheduler that hands ``errands``' tasks out, None if none does."""
    scheduler = getattr(errands, "scheduler", None)
    if scheduler is None:
        return None
    return getattr(scheduler, "__name__", type(scheduler).__name__)


def _not_simulated(instance: Any) -> tuple[str, ...]:
    """What of a 2026 instance the lock-step fleet does not model, in words: its actions'
    ticks (``agentCounter``) and its random delays (``delayConfig``). The command runs
    such an instance on ticks (:mod:`warehouse_phys.apps.simulate.on_ticks`); a lock-step
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
