"""Warehouse layouts: the presets, and turning a ``layout=`` argument into a grid.

A layout is text, one string per row: ``.`` floor, ``#`` shelf, ``P`` floor on
which packages may appear, ``S`` a start (the first is the robot's; a fleet uses all; see
:meth:`warehouse_phys.grid.WarehouseGrid.from_layout`). Each preset is
registered as ``warehouse-robot-<name>-v0`` (grid twin) and
``warehouse-robot-phys-<name>-v0`` (physics-backed), with a time limit that
suits its size. Like :mod:`warehouse_phys.grid`, this module imports neither
gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from warehouse_phys.grid import WarehouseGrid


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


def resolve_layout(layout: str | Sequence[str]) -> WarehouseGrid:
    """The grid of a preset name or of a layout's rows.

    Raises:
        ValueError: for an unknown preset name or an invalid layout (the
            message says which, and where).
        TypeError: if ``layout`` is neither a string nor a sequence of strings.
    """
    if isinstance(layout, str):
        preset = PRESETS.get(layout)
        if preset is None:
            raise ValueError(
                f"unknown layout preset {layout!r}; presets: {', '.join(sorted(PRESETS))} "
                "(or pass the rows as a list of strings)"
            )
        return WarehouseGrid.from_layout(preset.rows)
    return WarehouseGrid.from_layout(layout)
