"""Warehouse layouts: the presets, and turning a ``layout=`` argument into a grid.

A layout is text, one string per row: ``.`` floor, ``#`` shelf, ``P`` floor on
which packages may appear, ``S`` a start (the first is the robot's; a fleet uses all; see
:meth:`warehouse_phys.world.grid.WarehouseGrid.from_layout`). Each preset is
registered as ``warehouse-robot-<name>-v0`` (grid twin) and
``warehouse-robot-phys-<name>-v0`` (physics-backed), with a time limit that
suits its size. Like :mod:`warehouse_phys.world.grid`, this module imports neither
gymnasium, pymunk nor pygame.

Fleet floors: :data:`FLEET_PRESETS` names one, ``"warehouse"``, whose floor equals the
classic ``kiva-33-46.map`` of the multi-robot planning benchmarks cell for cell (made by
:func:`~warehouse_phys.world.maps.warehouse`). A ``layout=`` also takes the name of a
benchmark map the package ships (:data:`warehouse_phys.world.maps.MAPS`, such as
``"kiva-33-46"``) and a path ending in ``.map``, read by
:func:`~warehouse_phys.world.movingai.read_movingai`. The generators, the MovingAI reader
and writer and their names (``warehouse``, ``read_movingai``, ``write_movingai``, ...)
lived here and still import from here.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

from warehouse_phys.world.grid import DEFAULT_COLS, DEFAULT_ROWS, WarehouseGrid, refuse_durations
from warehouse_phys.world.layout_text import check_size
from warehouse_phys.world.maps import MAPS, map_path, warehouse
from warehouse_phys.world.movingai import (  # their old home: these names import from here too
    MAP_SLACK_BYTES,
    MAX_HEADER_BYTES,
    MAX_MAP_BYTES,
    MOVINGAI_BLOCKED,
    MOVINGAI_ENDPOINT,
    MOVINGAI_PASSABLE,
    read_movingai,
    write_movingai,
)

__all__ = [
    "EXACT_TIME_LIMIT_CELLS",
    "FLEET_PRESETS",
    "MAP_SLACK_BYTES",
    "MAX_HEADER_BYTES",
    "MAX_MAP_BYTES",
    "MOVINGAI_BLOCKED",
    "MOVINGAI_ENDPOINT",
    "MOVINGAI_PASSABLE",
    "PRESETS",
    "TIME_LIMIT_FINISH_RATE",
    "TIME_LIMIT_STEPS_PER_CELL",
    "Preset",
    "make_grid",
    "preset_ids",
    "preset_name",
    "read_movingai",
    "resolve_layout",
    "suggested_time_limit",
    "warehouse",
    "write_movingai",
]


@dataclass(frozen=True)
class Preset:
    """A named layout and the time limit of its registered environments."""

    name: str
    rows: tuple[str, ...]
    #: Time limit of the registered ids: :func:`suggested_time_limit`, within
    #: which a uniformly random walk reaches the package in at least 98 % of
    #: episodes, as on the default floor with its 200 steps.
    max_episode_steps: int
    #: Episodes with which the default trainer's greedy policy reaches every
    #: package by a shortest path (checked for several seeds by the tests).
    training_episodes: int
    description: str


PRESETS: dict[str, Preset] = {
    preset.name: preset
    for preset in (
        Preset(
            name="aisles",
            rows=(
                "S........",
                ".###.###.",
                ".........",
                ".###.###.",
                ".........",
                ".###.###.",
                ".........",
            ),
            max_episode_steps=1200,
            training_episodes=15_000,
            description="three rows of shelves with picking aisles between them; "
            "packages anywhere on the floor",
        ),
        Preset(
            name="depot",
            rows=(
                "S.......",
                ".##.###.",
                ".##.###.",
                "........",
                "##.##.##",
                "PP.PP.PP",
            ),
            max_episode_steps=1500,
            training_episodes=1000,
            description="storage shelves above a loading bay; packages wait at the six "
            "docks of the bay, reached through gaps in the bay's wall",
        ),
        Preset(
            name="maze",
            rows=(
                "S.#....",
                "..#.##.",
                "..#..#.",
                "....##.",
                "###....",
            ),
            max_episode_steps=900,
            training_episodes=5000,
            description="a small store room whose shelves force detours",
        ),
    )
}


#: The share of uniformly random episodes a time limit lets reach the package.
TIME_LIMIT_FINISH_RATE = 0.98
#: Floors with at most this many reachable cells get the exact random-walk limit.
EXACT_TIME_LIMIT_CELLS = 100
#: Time limit per reachable cell of a larger floor [steps/cell]: what the exact
#: limit comes to on open floors from 6 x 6 to 14 x 14 (11 to 12).
TIME_LIMIT_STEPS_PER_CELL = 12


def suggested_time_limit(grid: WarehouseGrid, granularity: int = 100) -> int:
    """A time limit for episodes on ``grid``, in whole ``granularity`` steps.

    On a floor of at most :data:`EXACT_TIME_LIMIT_CELLS` reachable cells it is
    the shortest limit within which a uniformly random walk reaches the package
    in at least 98 % of episodes, computed exactly: what the default floor's
    200 steps give (98.6 %), and how the presets' limits were chosen. Long
    enough for epsilon-greedy exploration to find the package early in
    training, short enough not to waste time.

    That exact limit grows like ``n log n`` with the ``n`` cells and costs far
    more to compute, so a larger floor gets :data:`TIME_LIMIT_STEPS_PER_CELL`
    steps per reachable cell instead (rounded up to ``granularity``): what the
    exact rule gives on open floors up to 14 x 14. It takes no time to compute.
    """
    if isinstance(granularity, bool) or not isinstance(granularity, int) or granularity < 1:
        raise ValueError(f"granularity must be a positive integer, got {granularity!r}")
    cells = len(grid.reachable)
    if cells > EXACT_TIME_LIMIT_CELLS:
        return -(-TIME_LIMIT_STEPS_PER_CELL * cells // granularity) * granularity
    return grid.random_walk_time_limit(TIME_LIMIT_FINISH_RATE, granularity)


def preset_name(rows: Sequence[str]) -> str | None:
    """The name of the preset whose layout is ``rows``, or ``None``."""
    for preset in PRESETS.values():
        if tuple(rows) == preset.rows:
            return preset.name
    return None


def preset_ids(name: str) -> tuple[str, str]:
    """The registered ids of preset ``name``: ``(grid twin, physics-backed)``."""
    return f"warehouse-robot-{name}-v0", f"warehouse-robot-phys-{name}-v0"


def resolve_layout(layout: str | os.PathLike[str] | Sequence[str]) -> WarehouseGrid:
    """The grid of a preset name (:data:`PRESETS` or :data:`FLEET_PRESETS`), of a shipped
    benchmark map's name (:data:`~warehouse_phys.world.maps.MAPS`), of a MovingAI map file
    (a path ending in ``.map``) or of a layout's rows.

    Raises:
        ValueError: for an unknown preset name, an unreadable or malformed map file or
            an invalid layout (the message says which, and where).
        TypeError: if ``layout`` is neither a string, a path nor a sequence of strings.
    """
    if isinstance(layout, os.PathLike) or (isinstance(layout, str) and layout.endswith(".map")):
        return read_movingai(layout)
    if isinstance(layout, str):
        if layout in FLEET_PRESETS:
            return WarehouseGrid.from_layout(FLEET_PRESETS[layout])
        if layout in MAPS:
            return read_movingai(map_path(layout))
        preset = PRESETS.get(layout)
        if preset is None:
            names = ", ".join(sorted([*PRESETS, *FLEET_PRESETS]))
            raise ValueError(
                f"unknown layout preset {layout!r}; presets: {names}; shipped maps: "
                f"{', '.join(MAPS)} (or pass the rows as a list of strings, or a MovingAI "
                ".map file)"
            )
        return WarehouseGrid.from_layout(preset.rows)
    return WarehouseGrid.from_layout(layout)


#: Floors for fleets, by name: larger than single-robot training suits, so they are not
#: registered as single-robot environments; every ``layout=`` takes their names.
FLEET_PRESETS: dict[str, tuple[str, ...]] = {
    # The classic Kiva warehouse of the planning benchmarks (kiva-33-46.map): 192 robots,
    # 256 steps, lifelong is where published fleets are compared.
    "warehouse": warehouse(),
}


def make_grid(
    grid_rows: int | None, grid_cols: int | None, layout: str | Sequence[str] | None
) -> WarehouseGrid:
    """The empty ``grid_rows`` x ``grid_cols`` floor (by default
    :data:`~warehouse_phys.world.grid.DEFAULT_ROWS` x
    :data:`~warehouse_phys.world.grid.DEFAULT_COLS`), or the layout's."""
    refuse_durations(grid_rows=grid_rows, grid_cols=grid_cols)
    if layout is None:
        return WarehouseGrid(
            DEFAULT_ROWS if grid_rows is None else grid_rows,
            DEFAULT_COLS if grid_cols is None else grid_cols,
        )
    for name, given in (("grid_rows", grid_rows), ("grid_cols", grid_cols)):
        if given is not None:
            check_size(name, given)
    grid = resolve_layout(layout)
    for name, given, actual in (
        ("grid_rows", grid_rows, grid.rows),
        ("grid_cols", grid_cols, grid.cols),
    ):
        if given is not None and given != actual:
            raise ValueError(f"{name}={given} contradicts the layout, which has {actual}")
    return grid
