"""The Q-table file: how large a table may be, its metadata, and the ``.npz`` format.

A table is saved as an ``.npz`` archive holding only numbers and a JSON string: the
float64 table as ``"q"`` and its metadata as ``"metadata"``
(:func:`~warehouse_phys.rl.qlearning.table_metadata` for one robot,
:func:`~warehouse_phys.rl.fleet_learning.fleet_table_metadata` for a fleet). It is written
atomically and read with :class:`~warehouse_phys.files.npzfile.NpzReader`, without pickle
and with strict checks of every entry, so loading a file can never run code. The
table's shape follows from its metadata: ``(R, C, R, C, 4)`` for one robot,
``(R, C, R, C, 5)`` for a fleet (the fifth action is WAIT), ``(R, C, R, C, 16, 5)``
for a fleet over neighbour masks.

A table and a training run's records must fit :data:`TRAINING_MEMORY_BUDGET`; the
learners check that before they allocate anything, and :func:`load_q_table` before
it reads a table. Everything here is re-exported by :mod:`warehouse_phys.rl.qlearning`.

Its length is the file format's checks: every field of a table file that may be
crafted or damaged is checked before a byte of the table is trusted.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from warehouse_phys.files.atomic import atomic_write
from warehouse_phys.files.npzfile import ArchiveError, NpzReader
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layout_text import MAX_SIDE
from warehouse_phys.world.layouts import PRESETS, preset_ids, preset_name

#: Largest metadata string read from a table file [bytes].
METADATA_MAX_BYTES = 2**20
#: Most robots a table file may name (a sanity bound on the metadata).
MAX_TABLE_ROBOTS = 1_000_000
#: The environments a table may name: the package's ids and, for a table trained on
#: an environment made without ``gym.make``, its class names.
_TABLE_ENV_IDS = frozenset(
    {
        "warehouse-robot-v0",
        "warehouse-robot-phys-v0",
        "WarehouseGridEnv",
        "WarehousePhysicsEnv",
        *(env_id for name in PRESETS for env_id in preset_ids(name)),
    }
)
_PRESET_OF_ID = {env_id: name for name in PRESETS for env_id in preset_ids(name)}

#: Identifies our archives; bumped if their layout ever changes.
TABLE_FORMAT = "warehouse_phys.qtable"
TABLE_FORMAT_VERSION = 1
#: The metadata every saved table carries, and the type of each entry.
_METADATA_FIELDS: dict[str, type | tuple[type, ...]] = {
    "format": str,
    "format_version": int,
    "env_id": str,
    "grid_rows": int,
    "grid_cols": int,
    "episodes": int,
    "alpha": (int, float),
    "gamma": (int, float),
    "seed": int,
    "package_version": str,
    # The floor's layout rows (None for the empty floor) and its preset name, if any.
    "layout": (list, type(None)),
    "layout_name": (str, type(None)),
}
#: Optional: the robots of a fleet that shares the table (absent: one robot). A fleet's
#: table has a fifth action, WAIT (see warehouse_phys.world.traffic).
_FLEET_FIELD = "robots"


#: Optional: the fleet observation a shared table reads, ``"local"`` (absent) or
#: ``"neighbours"`` (an axis of 16 neighbour masks before the actions).
_OBSERVATION_FIELD = "observation"
_NEIGHBOUR_MASKS = 16


def table_actions(metadata: dict[str, Any]) -> int:
    """Actions in the last axis of the table ``metadata`` describes: 4, or 5 for a fleet's."""
    return 5 if metadata.get(_FLEET_FIELD, 1) > 1 else 4


def table_kind(metadata: dict[str, Any]) -> str:
    """Which table ``metadata`` describes, in words: a single robot's, or a fleet's with
    its observation."""
    robots = metadata.get(_FLEET_FIELD, 1)
    if robots == 1:
        return "a single robot's table"
    observation = metadata.get(_OBSERVATION_FIELD, "local")
    return f"a {robots}-robot fleet's table over {observation!r} observations"


def table_tail(metadata: dict[str, Any]) -> tuple[int, ...]:
    """The axes of the table ``metadata`` describes after ``(R, C, R, C)``: the actions,
    after the 16 neighbour masks for a fleet's ``"neighbours"`` table."""
    masks = (_NEIGHBOUR_MASKS,) if metadata.get(_OBSERVATION_FIELD) == "neighbours" else ()
    return (*masks, table_actions(metadata))


#: Memory a training run may take for its Q-table and its per-episode records [bytes].
TRAINING_MEMORY_BUDGET = 2 * 2**30
#: Memory of one episode's records [bytes]: steps, return and epsilon (8 bytes each),
#: whether it reached the target and whether it was truncated (1 byte each).
RECORD_BYTES_PER_EPISODE = 26


def table_bytes(rows: int, cols: int, tail: tuple[int, ...] = (4,)) -> int:
    """Memory of the float64 Q-table of a ``rows`` x ``cols`` floor [bytes]: a single
    robot's by default, or one whose axes after ``(R, C, R, C)`` are ``tail`` (see
    :func:`table_tail`)."""
    return rows * cols * rows * cols * math.prod(tail) * 8


def check_training_memory(
    rows: int, cols: int, episodes: int, *, tail: tuple[int, ...] = (4,)
) -> None:
    """Refuse a run whose table and records would need more than the budget.

    Raises:
        ValueError: naming the sizes, if the Q-table of a ``rows`` x ``cols``
            floor (a single robot's, or one whose axes after ``(R, C, R, C)`` are
            ``tail``: see :func:`table_tail`) plus the records of ``episodes``
            episodes exceed :data:`TRAINING_MEMORY_BUDGET`.
    """
    table = table_bytes(rows, cols, tail)
    records = episodes * RECORD_BYTES_PER_EPISODE
    if table + records > TRAINING_MEMORY_BUDGET:
        records_text = (
            f" and {episodes} episodes need {_size(records)} of records" if episodes else ""
        )
        digits = 1  # enough to tell the table from the budget: 2.04 GiB, not 2.0 GiB
        while _size(table, digits) == _size(TRAINING_MEMORY_BUDGET) and digits < 6:
            digits += 1
        raise ValueError(
            f"a {rows}x{cols} floor needs a Q-table of {_size(table, digits)}{records_text}, "
            "more than "
            f"the {_size(TRAINING_MEMORY_BUDGET)} a training run may take; "
            "train on a smaller floor or fewer episodes"
        )


def _size(n_bytes: int, digits: int = 1) -> str:
    """``n_bytes`` for people: bytes, KiB, MiB, GiB or TiB, ``digits`` after the point."""
    value = float(n_bytes)
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if value < 1024:
            return f"{n_bytes} bytes" if unit == "bytes" else f"{value:.{digits}f} {unit}"
        value /= 1024
    return f"{value:,.{digits}f} TiB"


class QTableError(ValueError):
    """A Q-table file that cannot be used; the message names the file and the problem."""


class TrainingSettings(Protocol):
    """What a table's metadata records of the run that trained it (a
    :class:`~warehouse_phys.rl.qlearning.QLearningConfig`)."""

    episodes: int
    alpha: float
    gamma: float
    seed: int


def make_table_metadata(
    env_id: str,
    grid: WarehouseGrid,
    config: TrainingSettings,
    *,
    robots: int | None = None,
    observation: str = "local",
) -> dict[str, Any]:
    """The metadata saved with a table trained with ``config`` on the floor ``grid`` of
    the environment ``env_id``: every entry :func:`load_q_table` requires and, for a
    fleet's shared table (``robots`` given), its robots and ``observation``."""
    from warehouse_phys import __version__

    layout = grid.layout
    metadata: dict[str, Any] = {
        "format": TABLE_FORMAT,
        "format_version": TABLE_FORMAT_VERSION,
        "env_id": env_id,
        "grid_rows": grid.rows,
        "grid_cols": grid.cols,
        "episodes": config.episodes,
        "alpha": config.alpha,
        "gamma": config.gamma,
        "seed": config.seed,
        "package_version": __version__,
        "layout": None if layout is None else list(layout),
        "layout_name": None if layout is None else preset_name(layout),
    }
    if robots is not None:
        metadata[_FLEET_FIELD] = robots
        metadata[_OBSERVATION_FIELD] = observation
    return metadata


def save_q_table(path: str | os.PathLike[str], q: np.ndarray, metadata: dict[str, Any]) -> Path:
    """Save ``q`` and its ``metadata`` (see :func:`~warehouse_phys.rl.qlearning.table_metadata`)
    as an ``.npz`` archive.

    The archive holds the table as a float64 array ``"q"`` and the metadata as
    a JSON string ``"metadata"``: nothing that needs pickle to load. It is
    written to a temporary file first and moved into place, so a failure leaves
    no half-written file. Returns the path.

    Raises:
        QTableError: if the table or the metadata would not load back.
    """
    q = np.asarray(q)
    _check_metadata(metadata, where="metadata")
    check_table(
        q,
        metadata["grid_rows"],
        metadata["grid_cols"],
        where="table",
        tail=table_tail(metadata),
        kind=table_kind(metadata),
    )
    text = json.dumps(metadata, sort_keys=True)
    # No copy of a float64 table (numpy writes it into the archive a chunk at a time): a
    # 2 GiB table is saved within the training budget.
    table = q.astype(np.float64, copy=False)
    return atomic_write(
        path, lambda file: np.savez_compressed(file, q=table, metadata=np.array(text))
    )


def load_q_table(
    path: str | os.PathLike[str], *, rows: int | None = None, cols: int | None = None
) -> tuple[np.ndarray, dict[str, Any]]:
    """Load a table saved by :func:`save_q_table`; returns ``(q, metadata)``.

    With ``rows`` and ``cols``, the table must be for that grid. The file is
    read with ``allow_pickle=False``: a pickle payload is refused, never run.

    Raises:
        QTableError: naming the file and what is wrong with it: missing, not an
            ``.npz`` archive, truncated or corrupt, pickled data or an object
            array, missing or malformed metadata, a shape that does not match
            its grid or the requested one, NaN or infinite values.
    """
    path = Path(path)
    if not path.exists():
        raise QTableError(f"{path}: no such file")
    if not path.is_file():
        raise QTableError(f"{path}: not a file")
    try:
        with path.open("rb") as file:
            magic = file.read(4)
            if magic[:1] == b"\x80":
                raise QTableError(
                    f"{path}: holds pickled data, which is never loaded; expected an .npz"
                )
            if magic != b"PK\x03\x04":
                raise QTableError(f"{path}: not an .npz archive")
            file.seek(0)
            with NpzReader(file, members=("q", "metadata")) as archive:
                for name in ("q", "metadata"):
                    if name not in archive.names:
                        raise QTableError(f"{path}: has no {name!r} array; not a saved Q-table")
                metadata = _read_metadata(archive, where=str(path))
                grid = (metadata["grid_rows"], metadata["grid_cols"])
                if (rows, cols) != (None, None) and (rows, cols) != grid:
                    raise QTableError(
                        f"{path}: the table is for a {grid[0]}x{grid[1]} grid, not {rows}x{cols}"
                    )
                needed = table_bytes(*grid, table_tail(metadata))
                if needed > TRAINING_MEMORY_BUDGET:
                    budget = TRAINING_MEMORY_BUDGET / 2**30
                    raise QTableError(
                        f"{path}: a table for a {grid[0]}x{grid[1]} grid needs "
                        f"{needed / 2**30:.1f} GiB, more than the {budget:g} GiB a table may take"
                    )
                q = _read_table(
                    archive,
                    *grid,
                    where=str(path),
                    tail=table_tail(metadata),
                    kind=table_kind(metadata),
                )
    except ArchiveError as error:
        raise QTableError(f"{path}: {error}") from None
    except OSError as error:
        raise QTableError(f"{path}: cannot be read ({error.strerror or error})") from None
    return q, metadata


def _read_metadata(archive: NpzReader, *, where: str) -> dict[str, Any]:
    """The metadata of an archive, read within :data:`METADATA_MAX_BYTES` and checked."""
    header = archive.header("metadata", max_data_bytes=METADATA_MAX_BYTES)
    if header.dtype.kind != "U" or header.shape != ():
        raise QTableError(f"{where}: metadata is not a JSON string")
    # Held as ASCII bytes, a quarter of the file's four bytes a character (json.dumps
    # writes ASCII): with its parse, under the 1 MiB beside the table.
    text = archive.read_ascii("metadata", max_data_bytes=METADATA_MAX_BYTES)
    try:
        metadata = json.loads(text)
    except (ValueError, RecursionError) as error:  # JSONDecodeError, huge numbers, deep nesting
        reason = "nested too deeply" if isinstance(error, RecursionError) else error
        raise QTableError(f"{where}: metadata is not valid JSON ({reason})") from None
    _check_metadata(metadata, where=where)
    return metadata


def _read_table(
    archive: NpzReader,
    rows: int,
    cols: int,
    *,
    where: str,
    tail: tuple[int, ...] = (4,),
    kind: str = "",
) -> np.ndarray:
    """The table of an archive for a ``rows`` x ``cols`` grid: real floats, as float64,
    finite. Its header is checked before the table is allocated, and the data is read
    straight into it: loading holds the float64 table and a few chunks, whatever the
    stored float type."""
    expected = (rows, cols, rows, cols, *tail)
    widest = np.dtype(np.longdouble).itemsize
    header = archive.header("q", max_data_bytes=math.prod(expected) * widest)
    if header.dtype.kind != "f":
        raise QTableError(f"{where}: table has dtype {header.dtype}, expected real floats")
    if header.shape != expected:
        raise QTableError(
            f"{where}: table shape {header.shape} does not match its {rows}x{cols} grid "
            f"(expected {expected}{', ' + kind if kind else ''})"
        )
    with np.errstate(over="ignore"):  # a long double too large for float64 becomes inf: refused
        q = archive.read_array("q", expected, np.float64)
    if not _all_finite(q):
        raise QTableError(f"{where}: table holds NaN or infinite values")
    return q


def _all_finite(q: np.ndarray) -> bool:
    """Whether ``q`` holds no NaN or infinity, checked a chunk at a time (a whole-table
    mask would take an eighth of the table more)."""
    flat = q.ravel(order="K")  # a view of a contiguous table
    step = 2**16
    return all(np.isfinite(flat[i : i + step]).all() for i in range(0, flat.size, step))


def _check_metadata(metadata: Any, *, where: str) -> None:
    error = QTableError
    if not isinstance(metadata, dict):
        raise error(f"{where}: metadata must be a JSON object")
    for name, kind in _METADATA_FIELDS.items():
        if name not in metadata:
            raise error(f"{where}: metadata has no {name!r}")
        value = metadata[name]
        if isinstance(value, bool) or not isinstance(value, kind):
            raise error(f"{where}: metadata {name!r} has the wrong type: {_short(value)}")
    robots = metadata.get(_FLEET_FIELD, 1)
    is_count = isinstance(robots, int) and not isinstance(robots, bool)
    if not is_count or not 1 <= robots <= MAX_TABLE_ROBOTS:
        raise error(
            f"{where}: metadata {_FLEET_FIELD!r} is not 1 to {MAX_TABLE_ROBOTS:,}: {_short(robots)}"
        )
    observation = metadata.get(_OBSERVATION_FIELD, "local")
    if observation not in ("local", "neighbours") or (observation == "neighbours" and robots == 1):
        raise error(
            f"{where}: metadata {_OBSERVATION_FIELD!r} must be 'local' or, for a fleet, "
            f"'neighbours': {_short(observation)}"
        )
    if metadata["format"] != TABLE_FORMAT:
        raise error(f"{where}: not a {TABLE_FORMAT} file (format {_short(metadata['format'])})")
    if metadata["format_version"] != TABLE_FORMAT_VERSION:
        raise error(
            f"{where}: format version {_short(metadata['format_version'])} is not supported "
            f"(this version reads {TABLE_FORMAT_VERSION})"
        )
    for name, low, high in (
        ("grid_rows", 1, MAX_SIDE),
        ("grid_cols", 1, MAX_SIDE),
        ("episodes", 1, None),
        ("seed", 0, None),
        ("alpha", 0, 1),
        ("gamma", 0, 1),
    ):
        value = metadata[name]
        if (
            (isinstance(value, float) and not math.isfinite(value))
            or value < low
            or (high is not None and value > high)
            or (name == "alpha" and value == 0)
        ):
            raise error(f"{where}: metadata {name!r} is out of range: {_short(value)}")
    grid = (metadata["grid_rows"], metadata["grid_cols"])
    env_id, layout, layout_name = metadata["env_id"], metadata["layout"], metadata["layout_name"]
    if env_id not in _TABLE_ENV_IDS:
        raise error(f"{where}: metadata 'env_id' {_short(env_id)} is not a warehouse environment")
    if layout is None:
        if min(grid) < 2:
            raise error(f"{where}: grid {grid[0]}x{grid[1]} is smaller than 2x2")
        if layout_name is not None:
            raise error(
                f"{where}: metadata names the layout {_short(layout_name)} but holds no layout"
            )
        if env_id in _PRESET_OF_ID:
            raise error(f"{where}: metadata 'env_id' {env_id} is a preset's, but holds no layout")
        return
    try:
        layout_grid = WarehouseGrid.from_layout(layout)
    except (TypeError, ValueError) as problem:
        raise error(f"{where}: metadata 'layout' is not a valid layout: {problem}") from None
    if (layout_grid.rows, layout_grid.cols) != grid:
        raise error(
            f"{where}: metadata 'layout' is {layout_grid.rows}x{layout_grid.cols}, "
            f"not the {grid[0]}x{grid[1]} grid it names"
        )
    if layout_name != preset_name(layout):
        actual = preset_name(layout)
        raise error(
            f"{where}: metadata 'layout_name' is {_short(layout_name)}, but its layout is "
            + (f"the preset {actual!r}" if actual else "not a preset's")
        )
    if env_id in _PRESET_OF_ID and _PRESET_OF_ID[env_id] != layout_name:
        raise error(
            f"{where}: metadata 'env_id' {env_id} does not match its layout {_short(layout_name)}"
        )


def _short(value: Any) -> str:
    """``repr(value)``, cut to a length that fits a one-line message."""
    text = repr(value) if not isinstance(value, int) or abs(value) < 10**30 else "a huge number"
    return text if len(text) <= 60 else text[:57] + "..."


def check_table(
    q: np.ndarray,
    rows: int,
    cols: int,
    *,
    where: str,
    tail: tuple[int, ...] = (4,),
    kind: str = "",
) -> None:
    """Refuse a table ``q`` that is not numbers of shape ``(rows, cols, rows, cols, *tail)``
    or holds NaN or infinite values.

    Raises:
        QTableError: beginning with ``where``, naming the problem (and ``kind``, the
            table's kind in words, when the shape is wrong).
    """
    error = QTableError
    expected = (rows, cols, rows, cols, *tail)
    if q.dtype.kind not in "fiu":
        raise error(f"{where}: table has dtype {q.dtype}, expected numbers")
    if q.shape != expected:
        raise error(
            f"{where}: table shape {q.shape} does not match its {rows}x{cols} grid "
            f"(expected {expected}{', ' + kind if kind else ''})"
        )
    if not _all_finite(q):  # a chunk at a time: no mask of the whole table
        raise error(f"{where}: table holds NaN or infinite values")
