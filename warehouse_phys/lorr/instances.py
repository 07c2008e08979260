"""League of Robot Runners (LoRR) problem instances: read, checked and written.

A LoRR instance is a JSON file naming, relative to itself, a MovingAI map
(``mapFile``), a start file (``agentFile``) and a task file (``taskFile``), with
``teamSize`` robots and ``numTasksReveal``. The competition's three editions use it:

- **2023** (no ``version``): ``taskAssignmentStrategy`` is ``"roundrobin"`` (robot
  ``i``'s ``k``-th errand is task ``(i + k N) mod T``) or ``"greedy"`` (the next
  free robot takes the next task); every task is one location.
- **2024** (``"version": "2024 LoRR"``): a task is a sequence of locations visited
  in order; ``numTasksReveal x teamSize`` tasks are open at a time and a scheduler
  chooses which robot takes which.
- **2026** (``"version": "2026 LoRR"``): as 2024, with ``agentCounter`` (ticks per
  action) and ``agentSize``, kept here as read, and ``delayConfig`` (random delays),
  checked as LoRR checks it (:class:`warehouse_phys.execution.delays.DelayConfig`).

Start and task files hold a count, then one line per start or task; lines starting
with ``#`` (the ``# version ...`` line of 2024 and 2026) are comments anywhere, as
the competition's reader skips them. A location is one integer ``row * width + col``.
Like the competition's reader, only the counts' lines are read: a start file with
more starts than ``teamSize`` is read up to the team, a task file up to its count.

:func:`read_instance` returns a :class:`LorrInstance`: the floor, the starts and
the tasks as flat integer arrays (never one Python object per task: 500,000 tasks
read in about a tenth of a second). Every fault of a file is one ``ValueError``
line naming the file, the line and what is wrong. :func:`write_instance` writes an
instance back in its edition's format. The start and task files are read by
:mod:`warehouse_phys.lorr.instance_files`. Like :mod:`warehouse_phys.world.grid`, this
module imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.files.atomic import atomic_write_text

# The start and task files' reader lives in instance_files; MAX_LIST_BYTES is re-exported
# here, where it was first (see __all__).
from warehouse_phys.lorr.instance_files import MAX_LIST_BYTES, read_bytes, read_locations, shown
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import read_movingai, write_movingai

#: The task assignments of LoRR 2023 instances; 2024 and later use a scheduler.
ASSIGNMENTS = ("roundrobin", "greedy")
#: The assignment of instances with a ``version`` (2024 and later): a scheduler's choice.
SCHEDULED = "scheduler"
#: The editions whose ``version`` line this reader knows.
VERSIONS = ("2024 LoRR", "2026 LoRR")
#: Largest instance JSON read [bytes]: a few hundred bytes in every published one.
MAX_JSON_BYTES = 1 << 20
#: Most robots an instance may have (every published one has at most 10,000).
MAX_TEAM_SIZE = 1_000_000


@dataclass(frozen=True)
class PublishedFigure:
    """A published result on a LoRR instance (10,000 robots, 5,000 steps, 1 s a step on
    a 32-vCPU machine), with turning robots."""

    #: What the competition counts: ``"errands"`` (2023, a task is one errand) or ``"tasks"``.
    counts: str
    #: The best known solution's count, a step.
    best: float
    #: The competition's default entry, a step (``None`` where not published).
    default: float | None = None

    def describe(self) -> str:
        """One line: the figures and what they count."""
        default = "" if self.default is None else f", default entry {self.default}"
        return f"best known {self.best} {self.counts}/step{default} (turning robots)"

    def to_json(self) -> dict[str, Any]:
        return {"counts": self.counts, "best_per_step": self.best,
                "default_entry_per_step": self.default, "robots": "turning"}  # fmt: skip


#: The competition's published figures on its instances (the Benchmark-Archive; see
#: ``../shared/lorr/README.md``), by instance name.
PUBLISHED_FIGURES: dict[str, PublishedFigure] = {
    "MR23-I-10": PublishedFigure("errands", 38.9),
    "WAREHOUSE": PublishedFigure("tasks", 30.97, 12.78),
}


@dataclass(frozen=True, eq=False)
class LorrInstance:
    """A LoRR problem: a floor, where each robot starts, and the tasks to do.

    Locations are cell indices ``row * cols + col`` of :attr:`grid` (the
    competition's own numbering). Task ``t``'s stops are
    ``task_stops[task_offsets[t]:task_offsets[t + 1]]``, visited in order (one stop
    a task in 2023). Every robot faces east at the start, as in the competition.
    """

    #: The instance's name: its JSON file's stem.
    name: str
    #: The floor (the map file's; shelves are its ``@`` and ``T`` cells).
    grid: WarehouseGrid
    #: ``(teamSize,)`` int64: each robot's start.
    starts: np.ndarray
    #: ``(tasks + 1,)`` int64: where each task's stops begin in :attr:`task_stops`.
    task_offsets: np.ndarray
    #: Every task's stops, one after the other, int64.
    task_stops: np.ndarray
    #: Tasks open at a time per robot (``numTasksReveal``).
    num_tasks_reveal: float = 1.0
    #: ``"roundrobin"`` or ``"greedy"`` (2023), or ``"scheduler"`` (2024 and later).
    assignment: str = "roundrobin"
    #: The ``version`` line (``"2024 LoRR"``, ``"2026 LoRR"``), ``None`` for 2023.
    version: str | None = None
    #: Ticks per forward move or turn (``agentCounter``, 2026), ``None`` if not given.
    agent_counter: int | None = None
    #: The robot's safety square [cells] (``agentSize``, 2026), ``None`` if not given.
    agent_size: float | None = None
    #: The random delays (``delayConfig``, 2026), ``None`` if not given.
    delay: DelayConfig | None = None
    #: The JSON file it was read from, ``None`` for one built in memory.
    path: Path | None = None

    def __post_init__(self) -> None:
        for name in ("starts", "task_offsets", "task_stops"):
            array = np.array(getattr(self, name), dtype=np.int64).reshape(-1)
            array.flags.writeable = False
            object.__setattr__(self, name, array)
        _check_instance(self)

    @property
    def team_size(self) -> int:
        """Robots in the instance (``teamSize``)."""
        return len(self.starts)

    @property
    def num_tasks(self) -> int:
        """Tasks in the task file."""
        return len(self.task_offsets) - 1

    @property
    def year(self) -> int:
        """The competition's edition: 2023 without a ``version``, else its year."""
        return 2023 if self.version is None else int(self.version.split()[0])

    @property
    def stops_per_task(self) -> np.ndarray:
        """``(tasks,)`` int64: how many stops each task has."""
        return np.diff(self.task_offsets)

    @property
    def open_tasks(self) -> int:
        """Tasks open at a time: ``numTasksReveal x teamSize`` as the competition rounds
        it (down; at least one)."""
        return max(1, int(self.num_tasks_reveal * self.team_size))

    def task(self, index: int) -> np.ndarray:
        """Task ``index``'s stops (cell indices), in order."""
        return self.task_stops[self.task_offsets[index] : self.task_offsets[index + 1]]


def read_instance(path: str | os.PathLike[str]) -> LorrInstance:
    """The LoRR instance of a JSON file (see the module for the format).

    Raises:
        ValueError: one line naming the file (and its line) and the fault: a missing or
            unreadable file, JSON that is not an object, a missing or mistyped field, an
            unknown ``version`` or ``taskAssignmentStrategy``, a bad ``delayConfig``; a
            start or task file with a bad count or location, fewer starts than
            ``teamSize`` (with both counts), two robots on one start, a start or task
            on a blocked cell or off the map (with the counts of each).
    """
    json_path = Path(path)
    name = shown(json_path)
    data = _read_json(json_path, name)
    version = _optional(data, name, "version", str)
    if version is not None and version not in VERSIONS:
        raise ValueError(f"{name}: unknown version {version!r}; known: {', '.join(VERSIONS)}")
    if version is None:
        assignment = _required(data, name, "taskAssignmentStrategy", str)
        if assignment not in ASSIGNMENTS:
            raise ValueError(
                f"{name}: taskAssignmentStrategy must be one of {list(ASSIGNMENTS)}, "
                f"got {assignment!r}"
            )
    else:
        assignment = SCHEDULED
    team = _required(data, name, "teamSize", int)
    if not 1 <= team <= MAX_TEAM_SIZE:
        raise ValueError(f"{name}: teamSize must be 1 to {MAX_TEAM_SIZE:,}, got {team}")
    reveal = _optional(data, name, "numTasksReveal", float)
    reveal = 1.0 if reveal is None else reveal
    if not (math.isfinite(reveal) and 0 < reveal <= 1000):
        raise ValueError(f"{name}: numTasksReveal must be above 0 and at most 1000, got {reveal}")
    counter = _optional(data, name, "agentCounter", int)
    if counter is not None and not 1 <= counter <= 10_000:
        raise ValueError(f"{name}: agentCounter must be 1 to 10,000 ticks, got {counter}")
    size = _optional(data, name, "agentSize", float)
    if size is not None and not (math.isfinite(size) and 0 < size <= 1):
        raise ValueError(f"{name}: agentSize must be above 0 and at most 1 cell, got {size}")
    delay = _delay_config(data, name)
    folder = json_path.parent
    files = {key: _beside(folder, name, key, _required(data, name, key, str)) for key in _FILE_KEYS}
    grid = read_movingai(files["mapFile"])
    cells = grid.rows * grid.cols
    starts = read_locations(files["agentFile"], "start", limit=team, cells=cells, single=True)
    if len(starts[0]) - 1 < team:
        raise ValueError(
            f"{name}: teamSize is {team:,} but {shown(files['agentFile'])} has "
            f"{len(starts[0]) - 1:,} starts"
        )
    offsets, stops = read_locations(files["taskFile"], "task", limit=None, cells=cells)
    if len(offsets) == 1:
        raise ValueError(f"{shown(files['taskFile'])}, line 1: the file holds no task")
    return LorrInstance(
        name=json_path.stem,
        grid=grid,
        starts=starts[1][starts[0][:-1]],  # each start line's first location
        task_offsets=offsets,
        task_stops=stops,
        num_tasks_reveal=reveal,
        assignment=assignment,
        version=version,
        agent_counter=counter,
        agent_size=size,
        delay=delay,
        path=json_path,
    )


def as_instance(instance: LorrInstance | str | os.PathLike[str]) -> LorrInstance:
    """``instance`` itself, or the instance read from the path of its JSON file.

    Raises:
        TypeError: for anything else.
        ValueError: as :func:`read_instance`, for a bad file.
    """
    if isinstance(instance, LorrInstance):
        return instance
    if not isinstance(instance, (str, os.PathLike)):
        raise TypeError(
            f"instance must be a LorrInstance or the path of its JSON file, got {instance!r}"
        )
    return read_instance(instance)


def write_instance(
    instance: LorrInstance, path: str | os.PathLike[str], *, map_name: str | None = None
) -> Path:
    """Write ``instance`` as a LoRR JSON file at ``path``, with its map, start and task
    files in ``maps/``, ``agents/`` and ``tasks/`` beside it, in its edition's format;
    each file atomically. Returns the JSON's path. ``read_instance`` of it gives the
    same floor, starts, tasks and settings."""
    path = Path(path)
    folder, stem = path.parent, path.stem
    relative = {
        "mapFile": f"maps/{map_name or stem}.map",
        "agentFile": f"agents/{stem}.agents",
        "taskFile": f"tasks/{stem}.tasks",
    }
    for name in relative.values():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
    write_movingai(instance.grid, folder / relative["mapFile"])
    header = "" if instance.version is None else f"# version for LoRR {instance.year}\n"
    starts = "".join(f"{start}\n" for start in instance.starts.tolist())
    atomic_write_text(folder / relative["agentFile"],
                      f"{header}{instance.team_size}\n{starts}")  # fmt: skip
    stops = instance.task_stops.tolist()
    bounds = instance.task_offsets.tolist()
    lines = [",".join(map(str, stops[a:b])) for a, b in itertools.pairwise(bounds)]
    atomic_write_text(
        folder / relative["taskFile"], f"{header}{len(lines)}\n" + "".join(f"{t}\n" for t in lines)
    )
    data: dict[str, Any] = {**relative, "teamSize": instance.team_size}
    data["numTasksReveal"] = instance.num_tasks_reveal
    if instance.version is None:
        data["taskAssignmentStrategy"] = instance.assignment
    else:
        data["version"] = instance.version
    if instance.agent_counter is not None:
        data["agentCounter"] = instance.agent_counter
    if instance.agent_size is not None:
        data["agentSize"] = instance.agent_size
    if instance.delay is not None:
        data["delayConfig"] = instance.delay.to_json()
    return atomic_write_text(path, json.dumps(data, indent=4) + "\n")


# ---------------------------------------------------------------------------- helpers
_FILE_KEYS = ("mapFile", "agentFile", "taskFile")


class _LongInteger(int):
    """An integer of the JSON too long to read (more than :data:`_MOST_DIGITS` digits),
    kept as its number of digits so that the field's check names it."""

    def __repr__(self) -> str:
        return f"an integer of {int(self):,} digits"


#: Most digits of an integer the instance reader converts (no field takes more; Python
#: refuses past 4,300).
_MOST_DIGITS = 30


def _parse_int(text: str) -> int:
    digits = len(text.lstrip("-"))
    return _LongInteger(digits) if digits > _MOST_DIGITS else int(text)


def _read_json(path: Path, name: str) -> dict[str, Any]:
    data = read_bytes(path, MAX_JSON_BYTES, "instance")
    try:
        value = json.loads(data.decode("utf-8-sig"), parse_int=_parse_int)
    except UnicodeDecodeError:
        raise ValueError(f"{name}: not UTF-8 text; not a LoRR instance") from None
    except json.JSONDecodeError as error:
        raise ValueError(
            f"{name}, line {error.lineno}, column {error.colno}: not JSON: {error.msg}"
        ) from None
    except RecursionError:  # arrays or objects nested thousands deep
        raise ValueError(f"{name}: JSON nested too deeply; not a LoRR instance") from None
    if not isinstance(value, dict):
        raise ValueError(f"{name}: the instance must be a JSON object, got {type(value).__name__}")
    return value


def _typed(name: str, key: str, value: object, kind: type) -> Any:
    """``value`` of ``key`` as ``kind`` (int: a whole number; float: any real), or a
    ``ValueError``."""
    if kind is str:
        if not isinstance(value, str) or not value:
            raise ValueError(f"{name}: {key} must be a non-empty string, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name}: {key} must be a number, got {value!r}")
    if isinstance(value, _LongInteger) or (kind is float and abs(value) >= 2**1023):
        shown = value if isinstance(value, _LongInteger) else _LongInteger(len(str(abs(value))))
        raise ValueError(f"{name}: {key} is out of range: {shown!r}")
    if kind is int:
        if isinstance(value, float) and not value.is_integer():
            raise ValueError(f"{name}: {key} must be a whole number, got {value!r}")
        return int(value)
    return float(value)


def _required(data: dict[str, Any], name: str, key: str, kind: type) -> Any:
    if key not in data:
        raise ValueError(f"{name}: missing {key!r}")
    return _typed(name, key, data[key], kind)


def _optional(data: dict[str, Any], name: str, key: str, kind: type) -> Any:
    return None if key not in data else _typed(name, key, data[key], kind)


def _beside(folder: Path, name: str, key: str, relative: str) -> Path:
    """The file ``relative`` names, which must lie in the instance's ``folder`` or below
    it (as the competition's instances do): a path that leads out of it, ``..`` or from
    the root, is refused without being read, so an instance cannot make the reader open
    and quote any file of the machine."""
    path = folder / relative
    inside = os.path.relpath(os.path.normpath(path), os.path.normpath(folder))
    if inside == os.pardir or inside.startswith(os.pardir + os.sep) or os.path.isabs(inside):
        raise ValueError(
            f"{name}: {key} {relative!r} leads out of the instance's folder; an instance's "
            "files lie in its folder or below it"
        )
    return path


def _delay_config(data: dict[str, Any], name: str) -> DelayConfig | None:
    """The instance's ``delayConfig``, checked as LoRR checks it (one home:
    :class:`~warehouse_phys.execution.delays.DelayConfig`), or ``None``."""
    if "delayConfig" not in data:
        return None
    config = data["delayConfig"]
    long = [key for key, value in config.items() if isinstance(value, _LongInteger)] if (
        isinstance(config, dict)) else []  # fmt: skip
    if long:
        raise ValueError(f"{name}: delayConfig {long[0]} is out of range: {config[long[0]]!r}")
    try:
        return DelayConfig.from_json(data["delayConfig"])
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: {error}") from None


def _check_instance(instance: LorrInstance) -> None:
    """Refuse starts and tasks the floor cannot take, with counts."""
    grid = instance.grid
    cells = grid.rows * grid.cols
    blocked = grid.shelf_mask.reshape(-1)
    where = instance.name
    offsets, stops, starts = instance.task_offsets, instance.task_stops, instance.starts
    if not len(starts):
        raise ValueError(f"{where}: no robot")
    if len(offsets) < 2 or offsets[0] != 0 or (np.diff(offsets) < 1).any():
        raise ValueError(f"{where}: every task needs at least one stop")
    if offsets[-1] != len(stops):
        raise ValueError(f"{where}: task_offsets end at {offsets[-1]}, not at {len(stops)} stops")
    for what, locations in (("start", starts), ("task stop", stops)):
        off = (locations < 0) | (locations >= cells)
        if off.any():
            raise ValueError(
                f"{where}: {int(off.sum()):,} {what}s off the {grid.rows} x {grid.cols} map, "
                f"the first {int(locations[off][0])}"
            )
        on_shelf = blocked[locations]
        if on_shelf.any():
            first = int(locations[on_shelf][0])
            raise ValueError(
                f"{where}: {int(on_shelf.sum()):,} {what}s on blocked cells, the first "
                f"{first} (row {first // grid.cols}, col {first % grid.cols})"
            )
    unique, counts = np.unique(starts, return_counts=True)
    if (counts > 1).any():
        shared = int(unique[counts > 1][0])
        robots = np.flatnonzero(starts == shared).tolist()[:2]
        raise ValueError(
            f"{where}: {int((counts > 1).sum()):,} start cells hold two robots or more, "
            f"the first {shared} (robots {robots[0]} and {robots[1]})"
        )
    if instance.assignment not in (*ASSIGNMENTS, SCHEDULED):
        raise ValueError(f"{where}: unknown assignment {instance.assignment!r}")
    if (instance.assignment == SCHEDULED) != (instance.version is not None):
        raise ValueError(f"{where}: a scheduler assigns the tasks of 2024 and later, only")


__all__ = [
    "ASSIGNMENTS",
    "MAX_JSON_BYTES",
    "MAX_LIST_BYTES",
    "MAX_TEAM_SIZE",
    "PUBLISHED_FIGURES",
    "SCHEDULED",
    "VERSIONS",
    "LorrInstance",
    "PublishedFigure",
    "as_instance",
    "read_instance",
    "write_instance",
]
