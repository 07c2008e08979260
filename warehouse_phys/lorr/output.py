"""The League of Robot Runners' output file: what a run did, as the competition writes it.

:class:`RunRecord` keeps, step by step, every robot's planned action (what the policy
asked) and actual action (what it did: a move that traffic or a wall refused is a
wait), whether it had an errand, and the planner's time, in arrays of one byte per
robot and step. :func:`output_json` turns a record, its instance and its errand list
into the competition's output (the 2023 format for a 2023 instance, the 2024 format
for later ones; ``Input_Output_Format.md`` of the competition's start kit):

- ``actionModel``: ``"MAPF_T"`` for turning robots; four-direction runs are written as
  ``"MAPF"`` with the action letters the competition's viewer (PlanViz) reads for it:
  ``U`` (row + 1), ``D`` (row - 1), ``L``, ``R``, ``W``;
- ``teamSize``, ``start`` (``[row, col, "E"]``: every robot starts facing east);
- ``numTaskFinished`` (tasks), ``sumOfCost`` (every robot's steps with an errand),
  ``makespan`` (the most of those);
- ``actualPaths`` and ``plannerPaths``: one string of comma-separated action letters per
  robot (``F`` forward, ``R`` clockwise, ``C`` counter-clockwise, ``W`` wait);
- ``plannerTimes`` [s], ``errors`` (a move traffic refused or a wall stopped:
  ``[robot, -1, step, what]``), ``events`` and ``tasks`` in the edition's layout, and
  for 2024 and later ``actualSchedule``/``plannerSchedule`` and the error counts.

:func:`replay` walks ``actualPaths`` from ``start`` through the move rules and lists
every vertex or swap conflict (none in a run of the fleet: the traffic rule grants no
conflict), so a file can be checked without the competition's tools.

**Runs on ticks** (League of Robot Runners 2026: moves that take ``agentCounter`` ticks,
random delays; the asynchronous fleet, :mod:`warehouse_phys.execution.runner`): one
record entry is a tick, not a step. :func:`output_json` then also writes
``agentMaxCounter`` (the ticks a move takes) and ``delayIntervals`` (per robot its
``[start_tick, end_tick]`` pairs, the end the first tick free again, as LoRR's
``DelayGenerator`` writes them; empty lists when no delays are drawn), after
``teamSize``. A path holds one letter a tick: a move's letter on the tick the move ends
(the robot is then at rest on the cell it entered), ``W`` on every other tick, so
:func:`replay` walks it cell by cell, and finds no conflict (a robot ends its move into a
cell only as, or after, the robot before it leaves it). What differs from LoRR 2026's
own output:

- its paths are compressed segments ``[(t,row,col,ori,counter):(A d, ...)]``, an action
  a run of ticks (``FW10``: forward commanded for 10 ticks) with the robot's state at each
  segment's start (``outputSegmentSize`` ticks a segment); here the plain letters, a tick
  each, and no ``outputSegmentSize``;
- its robots turn (``"MAPF_T"``, a turn takes ``agentCounter`` ticks as a forward move
  does); here four-direction robots written as ``"MAPF"``;
- ``plannerPaths`` is here ``actualPaths`` again (the executor runs the planner's moves,
  late under delays but never others), and ``plannerTimes`` holds one entry a plan (the
  CPU time of the tick at which the planner ran, that tick's execution included);
- ``sumOfCost`` and ``makespan`` count ticks as this module counts steps (LoRR 2026 writes
  no ``sumOfCost`` and the run's length as ``makespan``), and there is no ``version``
  field;
- robots are points kept at least the executor's ``min_gap`` apart, not LoRR's squares
  of side ``agentSize`` checked for overlap.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from warehouse_phys.files.atomic import atomic_write
from warehouse_phys.lorr.errands import ErrandList
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid
from warehouse_phys.world.headings import ACTION_LETTERS, HEADING_LETTERS, HEADING_MOVES, TurnAction
from warehouse_phys.world.traffic import WAIT

#: The action letters of a four-direction run, by grid action (LEFT, DOWN, RIGHT, UP,
#: WAIT), as the competition's viewer reads the ``"MAPF"`` action model.
GRID_LETTERS = "LURDW"
#: The output's action models: turning robots and four-direction moves.
TURNING_MODEL, GRID_MODEL = "MAPF_T", "MAPF"


class RunRecord:
    """What every robot of a fleet did at each step, for the competition's output file.

    ``add(planned, actual, had_errand, seconds)`` once per step (or tick): ``(N,)`` the
    actions the policy asked for and those that happened (the move model's numbering),
    whether each robot had an errand at the step's start, and the planner's time [s]
    (``None`` at a tick at which the planner did not run). One byte per robot and action.
    """

    def __init__(self, num_robots: int, *, turning: bool) -> None:
        self.num_robots = num_robots
        self.turning = turning
        self._planned: list[np.ndarray] = []
        self._actual: list[np.ndarray] = []
        self.busy_steps = np.zeros(num_robots, dtype=np.int64)
        self.planner_seconds: list[float] = []
        #: ``(step, robot, action, what)`` of every action not taken as planned: a move
        #: that traffic refused or a wall stopped.
        self.errors: list[tuple[int, int, int, str]] = []

    @property
    def steps(self) -> int:
        return len(self._planned)

    def add(
        self,
        planned: np.ndarray,
        actual: np.ndarray,
        had_errand: np.ndarray,
        seconds: float | None,
    ) -> None:
        """One step's actions (see the class); ``seconds`` ``None`` adds no planner time."""
        planned = np.asarray(planned, dtype=np.int8)
        actual = np.asarray(actual, dtype=np.int8)
        self._planned.append(planned)
        self._actual.append(actual)
        self.busy_steps += np.asarray(had_errand, dtype=bool)
        if seconds is not None:
            self.planner_seconds.append(float(seconds))
        for robot in np.flatnonzero(planned != actual).tolist():
            self.errors.append((self.steps, robot, int(planned[robot]), "move refused"))

    def paths(self, which: str = "actual") -> Iterator[str]:
        """Each robot's actions as the output's comma-separated letters."""
        rows = self._actual if which == "actual" else self._planned
        letters = np.frombuffer((ACTION_LETTERS if self.turning else GRID_LETTERS).encode(), "S1")
        table = np.stack(rows, axis=1) if rows else np.zeros((self.num_robots, 0), np.int8)
        for robot_actions in table:
            yield ",".join(letters[robot_actions].astype(str).tolist())


def actual_actions(
    before: np.ndarray,
    after: np.ndarray,
    cols: int,
    headings_before: np.ndarray | None = None,
    headings_after: np.ndarray | None = None,
) -> np.ndarray:
    """The actions robots actually took, from their cell indices (and headings) before
    and after a step: a move or forward where the cell changed, a turn where the heading
    did, a wait otherwise."""
    moved = after - before
    if headings_before is None:
        actions = np.full(len(before), WAIT, dtype=np.int64)
        for action, (d_row, d_col) in enumerate(ACTION_DELTAS):
            actions[moved == d_row * cols + d_col] = action
        return actions
    turn = (headings_after - headings_before) % 4
    actions = np.full(len(before), TurnAction.WAIT, dtype=np.int64)
    actions[turn == 1] = TurnAction.CLOCKWISE
    actions[turn == 3] = TurnAction.COUNTERCLOCKWISE
    actions[moved != 0] = TurnAction.FORWARD
    return actions


def output_json(
    instance: LorrInstance,
    record: RunRecord,
    errands: ErrandList,
    *,
    agent_max_counter: int | None = None,
    delay_intervals: list[list[list[int]]] | None = None,
) -> Iterator[tuple[str, Any]]:
    """The output file's fields, in the competition's order, as ``(key, value)`` pairs
    (the paths as generators of strings, so that a 10,000-robot run is written
    without holding its JSON in memory). ``errands`` must have been kept with
    ``record=True``.

    A run on ticks gives ``agent_max_counter`` (the ticks a move takes): then
    ``agentMaxCounter`` and ``delayIntervals`` (``delay_intervals``, LoRR's per-robot
    ``[start, end]`` lists as :meth:`~warehouse_phys.execution.delays.DelayGenerator.intervals_json`
    gives them; an empty list a robot for ``None``) follow ``teamSize``.

    Raises:
        ValueError: for ``delay_intervals`` without ``agent_max_counter``, or not one list
            a robot.
    """
    n = instance.team_size
    if delay_intervals is not None and (agent_max_counter is None or len(delay_intervals) != n):
        raise ValueError(
            f"delay_intervals needs agent_max_counter and one list a robot ({n}), got "
            f"{len(delay_intervals)} lists, agent_max_counter {agent_max_counter}"
        )
    return _output_fields(instance, record, errands, agent_max_counter, delay_intervals)


def _output_fields(
    instance: LorrInstance,
    record: RunRecord,
    errands: ErrandList,
    agent_max_counter: int | None,
    delay_intervals: list[list[list[int]]] | None,
) -> Iterator[tuple[str, Any]]:
    """The fields of :func:`output_json`, its arguments checked."""
    n = instance.team_size
    cols = instance.grid.cols
    yield "actionModel", TURNING_MODEL if record.turning else GRID_MODEL
    yield "AllValid", "Yes" if not record.errors else "No"
    yield "teamSize", n
    if agent_max_counter is not None:
        yield "agentMaxCounter", int(agent_max_counter)
        yield "delayIntervals", delay_intervals or [[] for _ in range(n)]
    yield "start", [[int(s // cols), int(s % cols), HEADING_LETTERS[0]]
                    for s in instance.starts.tolist()]  # fmt: skip
    yield "numTaskFinished", errands.tasks_done
    yield "sumOfCost", int(record.busy_steps.sum())
    yield "makespan", int(record.busy_steps.max(initial=0))
    yield "actualPaths", record.paths("actual")
    yield "plannerPaths", record.paths("planned")
    yield "plannerTimes", record.planner_seconds
    yield "errors", [[robot, -1, step, what] for step, robot, _, what in record.errors]
    events = errands.events
    if instance.year == 2023:
        per_robot: list[list[list[Any]]] = [[] for _ in range(instance.team_size)]
        for step, robot, task in events.assigned:
            per_robot[robot].append([task, step, "assigned"])
        for step, robot, task, _ in events.finished:
            per_robot[robot].append([task, step, "finished"])
        yield "events", per_robot
        yield "tasks", [[task, int(instance.task(line)[0] // cols),
                         int(instance.task(line)[0] % cols)]
                        for task, _, line in events.revealed]  # fmt: skip
        return
    # 2024 and later: the competition records an assignment when it takes effect, at the
    # end of the step after the scheduler chose it.
    schedule = [[] for _ in range(instance.team_size)]
    for step, robot, task in events.assigned:
        schedule[robot].append(f"{step + 1}:{task}")
    strings = [",".join(entries) + ("," if entries else "") for entries in schedule]
    yield "actualSchedule", strings
    yield "plannerSchedule", strings
    yield "events", [list(event) for event in events.finished]
    yield "tasks", [[task, step, [int(v) for stop in instance.task(line).tolist()
                                  for v in divmod(stop, cols)]]
                    for task, step, line in events.revealed]  # fmt: skip
    yield "scheduleErrors", []
    yield "numPlannerErrors", len(record.errors)
    yield "numScheduleErrors", 0
    yield "numEntryTimeouts", 0


def write_output(
    path: str | os.PathLike[str],
    instance: LorrInstance,
    record: RunRecord,
    errands: ErrandList,
    *,
    agent_max_counter: int | None = None,
    delay_intervals: list[list[list[int]]] | None = None,
) -> Path:
    """Write the competition's output file (see :func:`output_json`, which also takes
    a run on ticks' ``agent_max_counter`` and ``delay_intervals``) atomically, streaming
    the paths; returns the path."""
    fields = output_json(instance, record, errands, agent_max_counter=agent_max_counter,
                         delay_intervals=delay_intervals)  # fmt: skip

    def write(file: Any) -> None:
        file.write(b"{\n")
        for index, (key, value) in enumerate(fields):
            file.write(b",\n" if index else b"")
            file.write(f"    {json.dumps(key)}: ".encode())
            if isinstance(value, Iterator):
                file.write(b"[")
                for number, text in enumerate(value):
                    file.write(b", " if number else b"")
                    file.write(json.dumps(text).encode())
                file.write(b"]")
            else:
                file.write(json.dumps(value).encode())
        file.write(b"\n}\n")

    return atomic_write(path, write)


class Replay(NamedTuple):
    """What walking an output's ``actualPaths`` through the move rules found."""

    #: ``(steps + 1, N)`` each robot's cell index at each step, the start first.
    cells: np.ndarray
    #: ``(steps + 1, N)`` each robot's heading (0 east, ..., all 0 for ``"MAPF"`` runs).
    headings: np.ndarray
    #: ``(step, robot, other robot, what)`` for every move off the floor or into a
    #: shelf, two robots on one cell or two robots swapping cells.
    conflicts: list[tuple[int, int, int, str]]


def replay(output: dict[str, Any], grid: WarehouseGrid) -> Replay:
    """Walk every robot's ``actualPaths`` from ``start`` (see :class:`Replay`).

    Raises:
        ValueError: if the output lacks a field or has an unknown action letter.
    """
    for key in ("actionModel", "teamSize", "start", "actualPaths"):
        if key not in output:
            raise ValueError(f"the output has no {key!r}")
    turning = output["actionModel"] == TURNING_MODEL
    letters = ACTION_LETTERS if turning else GRID_LETTERS
    cols, n = grid.cols, int(output["teamSize"])
    paths = [path.split(",") if path else [] for path in output["actualPaths"]]
    steps = max((len(path) for path in paths), default=0)
    actions = np.full((n, steps), letters.index("W"), dtype=np.int64)
    for robot, path in enumerate(paths[:n]):
        unknown = set(path) - set(letters)
        if unknown:
            raise ValueError(f"robot {robot}'s path has unknown actions {sorted(unknown)}")
        actions[robot, : len(path)] = [letters.index(letter) for letter in path]
    cells = np.empty((steps + 1, n), dtype=np.int64)
    headings = np.zeros((steps + 1, n), dtype=np.int64)
    cells[0] = [row * cols + col for row, col, *_ in output["start"][:n]]
    headings[0] = [HEADING_LETTERS.index(s[2]) if turning else 0 for s in output["start"][:n]]
    free = grid.free_mask.reshape(-1)
    conflicts: list[tuple[int, int, int, str]] = []
    for step in range(steps):
        act = actions[:, step]
        row, col = np.divmod(cells[step], cols)
        if turning:
            forward = act == TurnAction.FORWARD
            move = np.where(forward, HEADING_MOVES[headings[step]], WAIT)
            turn = np.array([0, 1, -1, 0])[act]
            headings[step + 1] = (headings[step] + turn) % 4
        else:
            move = act
            headings[step + 1] = headings[step]
        delta = np.array([*ACTION_DELTAS, (0, 0)])[move]
        to_row, to_col = row + delta[:, 0], col + delta[:, 1]
        inside = (to_row >= 0) & (to_row < grid.rows) & (to_col >= 0) & (to_col < cols)
        target = np.where(inside, to_row * cols + to_col, cells[step])
        off = ~inside | ~free[target]
        conflicts += [(step + 1, int(r), -1, "unallowed move") for r in np.flatnonzero(off)]
        cells[step + 1] = np.where(off, cells[step], target)
        conflicts += _conflicts(step + 1, cells[step], cells[step + 1])
    return Replay(cells, headings, conflicts)


def _conflicts(step: int, before: np.ndarray, after: np.ndarray) -> list[tuple[int, int, int, str]]:
    """Vertex conflicts (two robots on one cell) and swaps (two robots trading cells),
    with array operations."""
    found = []
    order = np.argsort(after, kind="stable")
    same = np.flatnonzero(after[order][1:] == after[order][:-1])
    found += [(step, int(order[k]), int(order[k + 1]), "vertex conflict") for k in same]
    moving = np.flatnonzero(after != before)
    if moving.size:
        cells = np.concatenate([before, after])
        occupant = np.full(int(cells.max()) + 1, -1, dtype=np.int64)
        occupant[before] = np.arange(len(before))
        other = occupant[after[moving]]
        swap = (other >= 0) & (other != moving)
        swap[swap] &= after[other[swap]] == before[moving[swap]]
        swap &= moving < other
        found += [
            (step, int(a), int(b), "edge conflict")
            for a, b in zip(moving[swap].tolist(), other[swap].tolist(), strict=True)
        ]
    return found
