"""Golden runs of the executor on our own floors (discs kept ``min_gap`` apart), recorded
before the executor learnt the start kit's square robots, so that its disc model stays
bit-identical.

Each run's inputs (the plans PIBT gave and the robots delayed, tick by tick) are kept in
``golden_runs.npz`` beside this file, so that the executor alone is replayed (a change to
the planners does not move them); ``GOLDEN`` holds the digest of every tick's commands and
robot states that the executor of commit 77acf42 gave for them.
``python -m tests.execution.golden_runs --record`` records the inputs again and prints the
digests.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import numpy as np

from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.execution.executor import Executor
from warehouse_phys.execution.runner import Execution
from warehouse_phys.world.headings import Heading
from warehouse_phys.world.layouts import make_grid

INPUTS = Path(__file__).with_name("golden_runs.npz")

#: (name, layout, robots, ticks a move, pDelay, turning, around_delays, ticks run)
RUNS = (
    ("warehouse-grid-T3", "warehouse", 40, 3, 0.01, False, "wait", 240),
    ("warehouse-grid-T1", "warehouse", 40, 1, 0.0, False, "wait", 120),
    ("warehouse-rotate-T3", "warehouse", 30, 3, 0.01, True, "wait", 240),
    ("aisles-grid-T10-reroute", "aisles", 6, 10, 0.02, False, "reroute", 300),
)

#: The digests the executor of commit 77acf42 (before squares) gave for the recorded inputs.
GOLDEN = {
    "warehouse-grid-T3": "028a326dc68ae910d9e04cd090b8647550d1ec8e69976f50fb82a7d5628414ba",
    "warehouse-grid-T1": "e5383f62bdcbf58fa2f7600b20f0eddb8b9e87834b7d06b19aa59ad95cd9ca5b",
    "warehouse-rotate-T3": "59bff833fe61c8d2439a3ae88ccf686524c3f293f0ba03c40720bc2d3680a322",
    "aisles-grid-T10-reroute": "1a391e3fc6b55337108c983eaf460f43e6363b9d054b3003b896eafc9dfd1355",
}


def record(name: str) -> dict[str, np.ndarray]:
    """Run PIBT windows through :class:`Execution` and keep its inputs to the executor."""
    _, layout, robots, ticks_per_move, p_delay, turning, around, ticks = _run(name)
    grid = make_grid(None, None, layout)
    room = np.argwhere(grid.reachable_mask)
    rng = np.random.default_rng(7)
    cells = room[rng.choice(len(room), robots, replace=False)]
    delays = DelayConfig(seed=3, min_delay=1, max_delay=20, event_model="bernoulli",
                         p_delay=p_delay, duration_model="uniform")  # fmt: skip
    headings = np.full(robots, Heading.EAST) if turning else None
    execution = Execution(grid, cells, ticks_per_move=ticks_per_move, delays=delays,
                          around_delays=around, headings=headings, seed=1)  # fmt: skip
    executor = execution.executor
    plans, plan_ticks, delayed = [], [], []
    add_plan = executor.add_plan

    def keep(path: np.ndarray) -> None:
        plans.append(np.asarray(path, dtype=np.int16))
        plan_ticks.append(executor.tick)
        add_plan(path)

    executor.add_plan = keep
    step = executor.step

    def kept_step(hold: np.ndarray | None = None) -> object:
        delayed.append(np.asarray(hold, dtype=bool))
        return step(hold)

    executor.step = kept_step
    goals = room[rng.choice(len(room), robots)]
    for _ in range(ticks):
        arrived = (executor.done == 0) & (executor.left == goals[:, 0] * grid.cols + goals[:, 1])
        if arrived.any():
            goals[arrived] = room[rng.choice(len(room), int(arrived.sum()))]
        execution.tick(goals)
    return {
        f"{name}/cells": cells,
        f"{name}/plans": np.stack(plans),
        f"{name}/plan_ticks": np.array(plan_ticks),
        f"{name}/delayed": np.stack(delayed),
    }


def digest(name: str, inputs: dict[str, np.ndarray] | None = None) -> str:
    """The sha256 of every tick of the executor replaying a run's recorded inputs:
    commands, advances, cells, ticks done, headings."""
    _, layout, robots, ticks_per_move, _, turning, _, ticks = _run(name)
    data = np.load(INPUTS) if inputs is None else inputs
    grid = make_grid(None, None, layout)
    headings = np.full(robots, Heading.EAST) if turning else None
    executor = Executor(grid, data[f"{name}/cells"], ticks_per_move, headings=headings)
    plans, plan_ticks = data[f"{name}/plans"], data[f"{name}/plan_ticks"].tolist()
    delayed = data[f"{name}/delayed"]
    sha = hashlib.sha256()
    for tick in range(ticks):
        if tick in plan_ticks:
            executor.add_plan(plans[plan_ticks.index(tick)].astype(np.int64))
        report = executor.step(delayed[tick])
        parts = [report.go, report.advanced, report.ended, report.knock_on, executor.left,
                 executor.entered, executor.done, executor.drift()]  # fmt: skip
        if executor.headings is not None:
            parts += [executor.headings, executor.facing]
        for part in parts:
            sha.update(np.ascontiguousarray(part).tobytes())
    return sha.hexdigest()


def _run(name: str) -> tuple:
    return next(run for run in RUNS if run[0] == name)


if __name__ == "__main__":
    if "--record" in sys.argv:
        inputs: dict[str, np.ndarray] = {}
        for run in RUNS:
            inputs |= record(run[0])
        np.savez_compressed(INPUTS, **inputs)
    for run in RUNS:
        print(f'    "{run[0]}": "{digest(run[0])}",')
