"""The League of Robot Runners' 2026 output file, written and read as the start kit writes it.

The start kit 3.1.0 (``BaseSystem::saveResults`` and ``Simulator::actual_path_to_json``)
writes, in this order: ``actionModel`` (``"MAPF_T"``), ``version`` (``"2026 LoRR"``),
``teamSize``, ``numTaskFinished``, ``makespan`` (the ticks simulated),
``numPlannerErrors``, ``numScheduleErrors``, ``numEntryTimeouts``, ``agentMaxCounter``
(ticks a forward move or a quarter turn takes), ``outputSegmentSize`` (100),
``delayIntervals`` (per robot its ``[start, end]`` ticks, the end the first tick free
again), ``start`` (``[row, col, "E"]``), ``actualPaths``, ``events``
(``[tick, robot, task, errands done]``), ``tasks`` (``[id, tick revealed, [row, col,
...]]``), ``plannerPaths``, ``plannerTimes``, ``errors`` (``[robot, other robot, tick,
what]``), ``actualSchedule``, ``plannerSchedule`` (per robot ``"tick:task,..."``) and
``scheduleErrors``.

**Paths** are segmented run-length strings, one segment a ``outputSegmentSize`` ticks:
``[(t,row,col,ori,counter):(F 3,W 2,R 3)]``: the segment's first tick ``t``, the robot's
state then, and its actions as runs (an action letter, a space, the ticks it lasted).
Letters: ``F`` forward, ``R`` clockwise (heading + 1: east to south), ``C``
counter-clockwise, ``W`` wait, ``T`` a tick the entry timed out (planner paths only). A
forward move of ``agentMaxCounter`` ticks is that many ``F`` ticks; a robot delayed, or
told STOP, waits (``W``) even in mid-move, where its counter holds.

The paths hold the ticks the kit ran its robots; ``makespan`` counts also the ticks in
which it only waited for a late entry, all robots still, without recording them (a first
plan later than ``initialPlanTimeLimit``, a ``process_new_plan`` over its limit): then
the paths are that many ticks shorter, their tick 0 is the first recorded tick, and the
events' ticks are the kit's (each recorded tick's index plus the unrecorded ones before).

What the kit 3.1.0 writes differently from its own documentation, and this module
instead as documented: every segment's header holds the robot's state at tick 0 (the kit
reads ``chunked_actual_snapshot_states[i][0]`` for every segment), here each segment's
own first state; the first schedule entry's tick is an uninitialised integer in the
kit's files (``TaskManager::curr_timestep`` before the first tick), here 0; the kit's
``numPlannerErrors`` and ``errors`` hold the action model's errors of the last tick
only (``ActionModelWithRotate::step`` clears its list each tick), here those of the
whole run. PlanViz (the competition's viewer) reads only each header's tick, and
:func:`read_output` reads both.

**Four-direction letters** (the ``"MAPF"`` action model of earlier editions, which
:mod:`warehouse_phys.lorr.output` writes for four-direction runs): ``U`` is row + 1
(south), ``D`` row - 1, ``L`` column - 1, ``R`` column + 1, as PlanViz reads them since
its commit ab86149 (17 November 2024, "fix mismatching between start-kit and planviz");
its files from 15 November 2023 to 16 November 2024 read ``U`` as row - 1 and ``D`` as
row + 1, and its earliest, of October 2023, as now.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from warehouse_phys.execution.swept_squares import colliding_pairs, square_corners
from warehouse_phys.files.atomic import atomic_write
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES
from warehouse_phys.world.traffic import neighbour_table

#: The kit's segment length [ticks] (``BaseSystem::simulate(..., 100)``).
SEGMENT_TICKS = 100
#: Action letters by the kit's action numbers (``Action``: FW, CR, CCR, W, NA).
LETTERS = "FRCWT"
#: The kit's numbers of the letters' actions.
FORWARD, CLOCKWISE, COUNTERCLOCKWISE, WAIT, TIMEOUT = range(5)
#: The version line of a 2026 output file.
VERSION = "2026 LoRR"
#: The keys of a 2026 output file, in the kit's order.
KEYS = (
    "actionModel", "version", "teamSize", "numTaskFinished", "makespan", "numPlannerErrors",
    "numScheduleErrors", "numEntryTimeouts", "agentMaxCounter", "outputSegmentSize",
    "delayIntervals", "start", "actualPaths", "events", "tasks", "plannerPaths",
    "plannerTimes", "errors", "actualSchedule", "plannerSchedule", "scheduleErrors",
)  # fmt: skip
_SEGMENT = re.compile(r"\[\((-?\d+),(-?\d+),(-?\d+),(-?\d+),(-?\d+)\):\(([^)]*)\)\]")


class SegmentedPaths:
    """Every robot's actions tick by tick, kept as the kit's segments: call :meth:`add`
    once a tick with the state before the tick and the action taken; :meth:`strings` gives
    the paths. Each segment is run-length encoded when it ends, so memory is the strings
    and one segment's ``(SEGMENT_TICKS, N)`` bytes."""

    def __init__(self, num_robots: int, segment: int = SEGMENT_TICKS) -> None:
        self.num_robots = num_robots
        self.segment = segment
        self.ticks = 0
        self._parts: list[list[str]] = [[] for _ in range(num_robots)]
        self._block = np.zeros((segment, num_robots), dtype=np.int8)
        self._header: list[str] = []

    def add(
        self, actions: np.ndarray, rows: np.ndarray, cols: np.ndarray, headings: np.ndarray,
        counters: np.ndarray,
    ) -> None:  # fmt: skip
        """One tick: ``(N,)`` the kit's action numbers, and each robot's state before the
        tick (row, column, heading, ticks done of its action)."""
        at = self.ticks % self.segment
        if at == 0:
            state = np.stack([rows, cols, headings, counters], axis=1).tolist()
            self._header = [f"[({self.ticks},{r},{c},{h},{k}):(" for r, c, h, k in state]
        self._block[at] = actions
        self.ticks += 1
        if at == self.segment - 1:
            self._close(self.segment)

    def strings(self) -> list[str]:
        """Each robot's path string (the current segment closed as it stands)."""
        at = self.ticks % self.segment
        parts = [list(robot) for robot in self._parts]
        if at:
            for robot, text in enumerate(self._encode(at)):
                parts[robot].append(text)
        return ["".join(robot) for robot in parts]

    def _close(self, length: int) -> None:
        for robot, text in enumerate(self._encode(length)):
            self._parts[robot].append(text)

    def _encode(self, length: int) -> list[str]:
        block = self._block[:length].T  # (N, length)
        change = np.ones_like(block, dtype=bool)
        change[:, 1:] = block[:, 1:] != block[:, :-1]
        robot, start = np.nonzero(change)
        ends = np.append(start[1:], length)
        ends[np.append(robot[1:] != robot[:-1], True)] = length
        runs = [
            f"{LETTERS[a]} {n}"
            for a, n in zip(block[robot, start].tolist(), (ends - start).tolist(), strict=True)
        ]
        bounds = np.searchsorted(robot, np.arange(self.num_robots + 1)).tolist()
        return [f"{self._header[i]}{','.join(runs[bounds[i]:bounds[i + 1]])})]"
                for i in range(self.num_robots)]  # fmt: skip


@dataclass
class Output2026:
    """A 2026 output file's fields (see the module); :func:`write_output` writes one."""

    team_size: int
    tasks_finished: int
    ticks: int
    agent_max_counter: int
    delay_intervals: list[list[list[int]]]
    starts: list[list[int]]
    actual_paths: list[str]
    planner_paths: list[str]
    events: list[list[int]] = field(default_factory=list)
    tasks: list[list[Any]] = field(default_factory=list)
    errors: list[list[Any]] = field(default_factory=list)
    actual_schedule: list[str] = field(default_factory=list)
    planner_schedule: list[str] = field(default_factory=list)
    schedule_errors: list[list[Any]] = field(default_factory=list)
    planner_times: list[float] = field(default_factory=list)
    entry_timeouts: int = 0
    segment: int = SEGMENT_TICKS

    def to_json(self) -> dict[str, Any]:
        """The file's JSON object, keys in the kit's order."""
        values = [
            "MAPF_T", VERSION, self.team_size, self.tasks_finished, self.ticks,
            len(self.errors), len(self.schedule_errors), self.entry_timeouts,
            self.agent_max_counter, self.segment, self.delay_intervals,
            [[r, c, "E"] for r, c in self.starts], self.actual_paths, self.events, self.tasks,
            self.planner_paths, self.planner_times, self.errors, self.actual_schedule,
            self.planner_schedule, self.schedule_errors,
        ]  # fmt: skip
        return dict(zip(KEYS, values, strict=True))


def write_output(path: str | os.PathLike[str], output: Output2026) -> Path:
    """Write ``output`` as the kit does (one line of JSON), atomically; returns the path."""
    text = json.dumps(output.to_json(), separators=(",", ":"))
    return atomic_write(path, lambda file: file.write(text.encode()))


@dataclass(frozen=True)
class ReadOutput:
    """A 2026 output file read back: its JSON and every robot's actions decoded."""

    data: dict[str, Any]
    #: ``(N, ticks)`` int8: each robot's actual action at each tick (the kit's numbers).
    actual: np.ndarray
    #: ``(N, ticks)`` int8: each robot's planned action (``T`` where the entry timed out).
    planned: np.ndarray | None

    @property
    def team_size(self) -> int:
        return int(self.data["teamSize"])


def read_output(path: str | os.PathLike[str]) -> ReadOutput:
    """A 2026 output file (the kit's or :func:`write_output`'s), checked and decoded.

    Raises:
        ValueError: one line naming the file and the fault: not JSON, not a 2026 file
            (no ``agentMaxCounter`` or ``outputSegmentSize``), a path that is not
            segments of the right ticks, an unknown letter, bad ``delayIntervals``.
    """
    name = os.fspath(path)
    try:
        data = json.loads(Path(path).read_bytes())
    except (OSError, ValueError) as error:
        raise ValueError(f"{name}: not a readable JSON output file ({error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{name}: not a LoRR output file (a JSON object)")
    for key in ("teamSize", "agentMaxCounter", "outputSegmentSize", "actualPaths"):
        if key not in data:
            raise ValueError(f"{name}: no {key!r}: not a LoRR 2026 output file")
    n = _integer(name, data, "teamSize", 1)
    segment = _integer(name, data, "outputSegmentSize", 1)
    actual = _decode_all(name, data["actualPaths"], n, segment, "actualPaths")
    planned = None
    if "plannerPaths" in data:
        planned = _decode_all(name, data["plannerPaths"], n, segment, "plannerPaths")
    delay_intervals(data, name)  # checked
    return ReadOutput(data, actual, planned)


class Walk(NamedTuple):
    """Every robot's state at each tick of an output's ``actualPaths`` (the start first):
    ``(ticks + 1, N)`` cell indices (the kit's ``location``: the cell a robot is on or
    leaves), headings, ticks done of the action in progress and the cell it enters; and
    ``(tick, robot, other robot)`` each pair whose squares collided in a tick."""

    cells: np.ndarray
    headings: np.ndarray
    done: np.ndarray
    entering: np.ndarray
    collisions: list[tuple[int, int, int]]


def walk(read: ReadOutput, grid: WarehouseGrid, agent_size: float = 1.0) -> Walk:
    """Walk ``read``'s actual actions from its ``start`` by the kit's rules
    (``ActionModelWithRotate::result_state``: an action advances its counter each tick it is
    taken, a wait holds it; at ``agentMaxCounter`` a forward move ends on the next cell,
    a turn on the next heading) and check every tick's squares of side ``agent_size``
    (:func:`~warehouse_phys.execution.swept_squares.colliding_pairs`).

    Raises:
        ValueError: for a start off the floor or a forward move into a wall or off it.
    """
    data, actual = read.data, read.actual
    n, ticks = actual.shape
    cols, needed = grid.cols, int(data["agentMaxCounter"])
    ahead = neighbour_table(grid)[:, HEADING_MOVES]
    cells = np.empty((ticks + 1, n), dtype=np.int64)
    headings = np.zeros((ticks + 1, n), dtype=np.int64)
    done = np.zeros((ticks + 1, n), dtype=np.int64)
    entering = np.empty((ticks + 1, n), dtype=np.int64)
    starts = np.array([[row, col] for row, col, *_ in data["start"]], dtype=np.int64)
    cells[0] = starts[:, 0] * cols + starts[:, 1]
    if not grid.free_mask.reshape(-1)[cells[0]].all():
        raise ValueError("a robot starts off the floor")
    entering[0] = cells[0]
    collisions: list[tuple[int, int, int]] = []
    span = np.full(n, needed)
    for t in range(ticks):
        act, here, face = actual[:, t], cells[t], headings[t]
        going = (act == FORWARD) | (act == CLOCKWISE) | (act == COUNTERCLOCKWISE)
        forward = act == FORWARD
        mid = done[t] > 0  # an action under way goes on to its cell, whatever the letter
        target = np.where(mid, entering[t], np.where(forward, ahead[here, face], here))
        wall = forward & ~mid & (target == here)
        if wall.any():
            raise ValueError(f"robot {int(np.flatnonzero(wall)[0])} drives into a wall at tick {t}")
        count = done[t] + going
        ends = going & (count >= needed)
        turn = np.where(act == CLOCKWISE, 1, np.where(act == COUNTERCLOCKWISE, 3, 0))
        cells[t + 1] = np.where(ends & forward, target, here)
        headings[t + 1] = np.where(ends, (face + turn) % 4, face)
        done[t + 1] = np.where(ends, 0, count)
        entering[t + 1] = np.where(done[t + 1] > 0, target, cells[t + 1])
        start = square_corners(here, target, done[t], span, cols)
        end = square_corners(cells[t + 1], entering[t + 1], done[t + 1], span, cols)
        pairs = colliding_pairs(start, end, here, agent_size, cols)
        collisions += [(t, int(a), int(b)) for a, b in pairs.tolist()]
    return Walk(cells, headings, done, entering, collisions)


def delay_intervals(data: dict[str, Any], name: str = "output") -> list[list[list[int]]]:
    """An output's ``delayIntervals``, checked: one list a robot of ``[start, end]`` pairs,
    ``0 <= start < end``, in order, never two at once.

    Raises:
        ValueError: one line naming ``name``, the robot and the fault.
    """
    n = _integer(name, data, "teamSize", 1)
    intervals = data.get("delayIntervals")
    if not isinstance(intervals, list) or len(intervals) != n:
        raise ValueError(f"{name}: delayIntervals must be one list a robot ({n})")
    for robot, pairs in enumerate(intervals):
        if not isinstance(pairs, list):
            raise ValueError(f"{name}: delayIntervals of robot {robot} is not a list")
        last = 0
        for pair in pairs:
            ok = (
                isinstance(pair, list)
                and len(pair) == 2
                and all(isinstance(v, int) and not isinstance(v, bool) for v in pair)
            )
            if not ok or not last <= pair[0] < pair[1]:
                raise ValueError(
                    f"{name}: delayIntervals of robot {robot}: {pair!r} is not a "
                    f"[start, end] pair in order (0 <= start < end, after {last})"
                )
            last = pair[1]
    return intervals


def decode_path(text: str, segment: int) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """One path string: ``(ticks,)`` int8 action numbers and each segment's header
    ``(tick, row, col, heading, counter)``.

    Segments follow each other, each of ``segment`` ticks but the last with ticks; the kit
    writes empty segments after it for the ticks it did not record (a late entry).

    Raises:
        ValueError: for text that is not such segments, or an unknown letter.
    """
    actions: list[np.ndarray] = []
    headers: list[tuple[int, ...]] = []
    cursor, tick, ended = 0, 0, False
    for match in _SEGMENT.finditer(text):
        if text[cursor : match.start()].strip():
            raise ValueError(f"text between segments at character {cursor}")
        header = tuple(int(v) for v in match.groups()[:5])
        part = _runs(match.group(6))
        cursor = match.end()
        if ended and len(part):
            raise ValueError(f"segment at tick {header[0]} follows a short one")
        if not ended and header[0] != tick:
            raise ValueError(f"segment starts at tick {header[0]}, expected {tick}")
        if len(part) > segment:
            raise ValueError(f"segment at tick {header[0]} holds {len(part)} ticks, not {segment}")
        ended = ended or len(part) < segment
        tick += len(part)
        headers.append(header)
        actions.append(part)
    if text[cursor:].strip():
        raise ValueError(f"trailing text at character {cursor}")
    joined = np.concatenate(actions) if actions else np.zeros(0, dtype=np.int8)
    return joined, headers


def _runs(text: str) -> np.ndarray:
    """A segment's runs (``F 3,W 2``) as one action number a tick."""
    letters, counts = [], []
    for run in (run.split() for run in text.split(",") if run.strip()):
        if len(run) != 2 or run[0] not in LETTERS or not run[1].isdigit():
            raise ValueError(f"run {' '.join(run)!r} is not '<letter> <ticks>'")
        letters.append(LETTERS.index(run[0]))
        counts.append(int(run[1]))
    return np.repeat(np.array(letters, dtype=np.int8), counts)


def _decode_all(name: str, paths: object, n: int, segment: int, key: str) -> np.ndarray:
    if not isinstance(paths, list) or len(paths) != n or not all(isinstance(p, str) for p in paths):
        raise ValueError(f"{name}: {key} must be one string a robot ({n})")
    rows = []
    for robot, text in enumerate(paths):
        try:
            rows.append(decode_path(text, segment)[0])
        except ValueError as error:
            raise ValueError(f"{name}: {key} of robot {robot}: {error}") from None
    ticks = {len(row) for row in rows}
    if len(ticks) > 1:
        raise ValueError(f"{name}: {key} cover different numbers of ticks: {sorted(ticks)}")
    return np.stack(rows) if rows else np.zeros((0, 0), dtype=np.int8)


def _integer(name: str, data: dict[str, Any], key: str, least: int) -> int:
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise ValueError(f"{name}: {key} must be an integer of at least {least}, got {value!r}")
    return value
