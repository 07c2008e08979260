"""Warehouse layouts: the presets, and turning a ``layout=`` argument into a grid.

A layout is text, one string per row: ``.`` floor, ``#`` shelf, ``P`` floor on
which packages may appear, ``S`` the robot's start (see
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


def suggested_time_limit(grid: WarehouseGrid, granularity: int = 100) -> int:
    """The shortest time limit, in whole ``granularity`` steps, within which a uniformly
    random walk reaches the package in at least 98 % of episodes.

    That is what the default floor's 200 steps give (98.6 %), and how the
    presets' limits were chosen. Long enough for epsilon-greedy exploration to
    find the package early in training, short enough not to waste time.
    """
    limit = granularity
    while grid.random_walk_finish_rate(limit) < TIME_LIMIT_FINISH_RATE:
        limit += granularity
    return limit


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
