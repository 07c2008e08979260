"""Drawing the warehouse: one renderer for every environment of the package.

The renderer knows nothing about episodes or physics. It draws a floor of
``rows`` x ``cols`` tiles, the package on its cell, the robot at a *continuous*
position in cell units and a status line under the grid. Positions are
``(row, col)`` floats in which whole numbers are cell centres, so ``(0.5, 1.0)``
is half-way between the centres of cells (0, 1) and (1, 1).

pygame is imported only when a picture is first drawn: an environment made
with ``render_mode=None`` (or ``"ansi"``) never loads it.

The other pictures of a floor live beside it: the array-drawn maps of large fleets
(:mod:`~warehouse_phys.drawing.map_frames`), the text frames
(:mod:`~warehouse_phys.drawing.text_frames`), the shared colours
(:mod:`~warehouse_phys.drawing.colours`) and pygame's import and the display check
(:mod:`~warehouse_phys.drawing.display`). Their names still import from here.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

# The colours, the display check, the map and the text frames live in modules of their
# own; re-exported here, where they lived first (see __all__).
from warehouse_phys.drawing.colours import DELIVERED_FRAME, FLEET_COLOURS, HEADING_POINTER
from warehouse_phys.drawing.display import NoDisplayError, check_display, import_pygame
from warehouse_phys.drawing.map_frames import (
    MAP_DELIVERED,
    MAP_FLOOR,
    MAP_FRAME_WIDTH_PX,
    MAP_PACKAGE,
    MAP_ROBOT_COLOURS,
    MAP_SHELF,
    fleet_map_frame,
    map_cell_px,
    stamp_fleet,
    stamp_headings,
)
from warehouse_phys.drawing.text_frames import HEADING_GLYPHS, ansi_frame, fleet_ansi_frame

if TYPE_CHECKING:
    import pygame

SPRITE_NAMES = ("robot.png", "floor.png", "package.png", "shelf.png")

#: Where sprites are looked for, in order: package data inside an installed
#: wheel, then the ``sprites/`` folder of a source checkout.
SPRITE_DIRS: tuple[Path, ...] = (
    Path(__file__).resolve().parent.parent / "sprites",
    Path(__file__).resolve().parent.parent.parent / "sprites",
)

DEFAULT_CELL_PX = 64  # [px] side of one floor cell on screen
MIN_CELL_PX = 16  # [px] below this the status font no longer fits a 2-column grid

#: The largest frame the renderer draws [px]: pygame and SDL cannot hold surfaces
#: much wider or taller, and an RGB array of this many pixels takes 96 MiB.
MAX_FRAME_SIDE_PX = 16384
MAX_FRAME_PIXELS = 2**25

STATUS_BACKGROUND = (38, 42, 48)  # RGB
STATUS_TEXT = (235, 235, 235)  # RGB


def sprite_path(name: str) -> Path:
    """The file of sprite ``name`` (for example ``"robot.png"``).

    Raises:
        FileNotFoundError: if no sprite folder holds the file; the message
            lists the folders searched and how to regenerate the images.
    """
    for folder in SPRITE_DIRS:
        candidate = folder / name
        if candidate.is_file():
            return candidate
    searched = ", ".join(str(folder) for folder in SPRITE_DIRS)
    raise FileNotFoundError(
        f"sprite {name!r} not found (searched: {searched}); reinstall warehouse_phys, "
        "or regenerate the images in a source checkout with `python sprites/make_sprites.py`"
    )


def fit_text(text: pygame.Surface, width: int) -> pygame.Surface:
    """``text`` (a rendered line), shrunk to ``width`` pixels if it is wider: narrow
    windows show the whole line, smaller, rather than clip it."""
    if text.get_width() <= width:
        return text
    pg = import_pygame()
    height = max(1, text.get_height() * width // text.get_width())
    return pg.transform.smoothscale(text, (width, height))


class FrameTooLargeError(ValueError):
    """A floor whose frames at the chosen cell size are too large to draw; ``size`` is
    the frame's ``(width, height)`` [px]."""

    def __init__(self, message: str, size: tuple[int, int]) -> None:
        super().__init__(message)
        self.size = size


class WarehouseRenderer:
    """Draws warehouse frames and, in ``human`` mode, owns the window.

    Args:
        rows: Number of grid rows.
        cols: Number of grid columns.
        shelves: Cells drawn as shelves.
        cell_px: Side of one cell on screen [px].
        render_fps: Pace of :meth:`show` [frames/s].
        title: Window caption.
    """

    def __init__(
        self,
        rows: int,
        cols: int,
        *,
        shelves: Iterable[tuple[int, int]] = (),
        cell_px: int = DEFAULT_CELL_PX,
        render_fps: float = 4,
        title: str = "warehouse_phys",
    ) -> None:
        if isinstance(cell_px, bool) or not isinstance(cell_px, (int, np.integer)):
            raise TypeError(f"cell_px must be an integer, got {cell_px!r}")
        if cell_px < MIN_CELL_PX:
            raise ValueError(f"cell_px must be at least {MIN_CELL_PX}, got {cell_px}")
        self.rows = rows
        self.cols = cols
        self.shelves = tuple(shelves)
        self.cell_px = int(cell_px)
        #: Pace of :meth:`show` [frames/s].
        self.render_fps = render_fps
        self.title = title
        self.status_px = max(20, self.cell_px * 3 // 8)  # [px] height of the status line
        #: Width of a frame [px]: the columns.
        self.width = cols * self.cell_px
        #: Height of a frame [px]: the rows and the status line under them.
        self.height = rows * self.cell_px + self.status_px
        #: Whether frames of this size can be drawn; see :meth:`check_frame_size`.
        self.frame_too_large = (
            max(self.width, self.height) > MAX_FRAME_SIDE_PX
            or self.width * self.height > MAX_FRAME_PIXELS
        )
        #: True once the user closed the window or pressed Escape: :meth:`show`
        #: then draws nothing more, and the host process carries on.
        self.closed_by_user = False

        self._pg: Any = None
        self._floor: pygame.Surface | None = None
        self._robot: pygame.Surface | None = None
        self._package: pygame.Surface | None = None
        self._package_carried: pygame.Surface | None = None
        self._canvas: pygame.Surface | None = None
        self._font: Any = None
        self._status_cache: tuple[str, pygame.Surface] | None = None
        self._window: pygame.Surface | None = None
        self._clock: Any = None

    @classmethod
    def for_grid(
        cls, grid: Any, *, cell_px: int, render_fps: float, title: str = "warehouse_phys"
    ) -> WarehouseRenderer:
        """The renderer of a :class:`~warehouse_phys.world.grid.WarehouseGrid`'s floor and
        shelves."""
        return cls(
            grid.rows,
            grid.cols,
            shelves=grid.shelves,
            cell_px=cell_px,
            render_fps=render_fps,
            title=title,
        )

    def check_frame_size(self) -> None:
        """Refuse, with a message naming the size, frames too large to draw.

        Raises:
            ValueError: if a frame would be wider or taller than
                :data:`MAX_FRAME_SIDE_PX` or hold more than :data:`MAX_FRAME_PIXELS`.
        """
        if self.frame_too_large:
            raise FrameTooLargeError(
                f"a {self.rows}x{self.cols} floor at cell_px={self.cell_px} makes frames of "
                f"{self.width}x{self.height} pixels, more than can be drawn (at most "
                f"{MAX_FRAME_SIDE_PX} pixels a side and {MAX_FRAME_PIXELS} in all); "
                f"lower cell_px (at least {MIN_CELL_PX}) or render a smaller floor",
                (self.width, self.height),
            )

    def __getstate__(self) -> dict[str, Any]:
        """What a copy or a pickle keeps: the settings, not pygame's surfaces or window.

        A copied renderer loads its sprites again when it first draws, and a
        copy of a ``human`` environment opens its own window when it first shows.
        """
        state = self.__dict__.copy()
        state.update(
            _pg=None,
            _floor=None,
            _robot=None,
            _package=None,
            _package_carried=None,
            _canvas=None,
            _font=None,
            _status_cache=None,
            _window=None,
            _clock=None,
        )
        return state

    # ------------------------------------------------------------------ drawing
    def draw(
        self,
        robot: Sequence[float],
        target: tuple[int, int],
        status: str = "",
        surface: pygame.Surface | None = None,
    ) -> pygame.Surface:
        """Draw one frame onto ``surface`` (an off-screen canvas by default) and return it.

        Args:
            robot: The robot's ``(row, col)`` position in cell units; whole
                numbers are cell centres, fractions lie between cells.
            target: The package's cell.
            status: Text of the status line under the grid (``""`` for none).
            surface: Where to draw; must be :attr:`width` x :attr:`height`.
        """
        pg = self._ensure_pygame()
        surface = self._floor_and_status(status, surface)
        px = self.cell_px
        surface.blit(self._package, (target[1] * px, target[0] * px))
        surface.blit(self._robot, (round(robot[1] * px), round(robot[0] * px)))
        if robot[0] == target[0] and robot[1] == target[1]:
            # Delivered: the robot carries the package, and its cell is framed.
            left, top = target[1] * px, target[0] * px
            surface.blit(self._package_carried, (left + px // 2, top))
            pg.draw.rect(surface, DELIVERED_FRAME, (left, top, px, px), width=max(2, px // 16))
        return surface

    def _floor_and_status(self, status: str, surface: pygame.Surface | None) -> pygame.Surface:
        """``surface`` (the off-screen canvas by default) with the floor and the status line."""
        pg = self._pg
        if surface is None:
            if self._canvas is None:
                self._canvas = pg.Surface((self.width, self.height))
            surface = self._canvas
        px = self.cell_px
        surface.blit(self._floor, (0, 0))
        surface.fill(STATUS_BACKGROUND, (0, self.rows * px, self.width, self.status_px))
        if status:
            text = self._status_surface(status)
            y = self.rows * px + (self.status_px - text.get_height()) // 2
            surface.blit(text, (self._status_margin(), y))
        return surface

    def rgb_array(
        self, robot: Sequence[float], target: tuple[int, int], status: str = ""
    ) -> np.ndarray:
        """One frame as a fresh ``(height, width, 3)`` uint8 array; needs no display."""
        pg = self._ensure_pygame()
        surface = self.draw(robot, target, status)
        return np.ascontiguousarray(pg.surfarray.pixels3d(surface).transpose(1, 0, 2))

    def fleet_rgb_array(
        self,
        robots: Sequence[Sequence[float]],
        packages: Sequence[tuple[int, int]],
        status: str = "",
        delivered: Sequence[bool] | None = None,
        headings: Sequence[float] | None = None,
    ) -> np.ndarray:
        """A frame of a fleet: robot ``i`` at ``robots[i]`` (cell units, as in :meth:`draw`)
        in a ring of colour ``FLEET_COLOURS[i]``, its package framed in the same colour (the
        frame stays visible round a robot standing on it); a robot whose ``delivered`` is
        true stands in a green frame, as the single robot's delivery is shown. With
        ``headings`` (turning robots: quarter turns clockwise from east, fractions while
        a robot turns) a dark pointer runs from each robot's centre to its rim.

        On cells under :data:`FLEET_SPRITE_MIN_PX` the robots are discs of their colour and
        the packages dark squares in a frame of their robot's colour, all drawn with array
        operations in one pass (a thousand robots cost no more than a few)."""
        pg = self._ensure_pygame()
        surface = self._floor_and_status(status, None)
        px = self.cell_px
        border = max(2, px // 16)
        if px < FLEET_SPRITE_MIN_PX:
            frame = np.ascontiguousarray(pg.surfarray.pixels3d(surface).transpose(1, 0, 2))
            stamp_fleet(frame, px, border, robots, packages, delivered)
            if headings is not None:
                stamp_headings(frame, px, robots, headings)
            return frame
        for i, (row, col) in enumerate(packages):
            colour = FLEET_COLOURS[i % len(FLEET_COLOURS)]
            surface.blit(self._package, (col * px, row * px))
            pg.draw.rect(surface, colour, (col * px, row * px, px, px), width=border)
        for i, (row, col) in enumerate(robots):
            colour = FLEET_COLOURS[i % len(FLEET_COLOURS)]
            centre = (round((col + 0.5) * px), round((row + 0.5) * px))
            pg.draw.circle(surface, colour, centre, px * 9 // 20)
            surface.blit(self._robot, (round(col * px), round(row * px)))
            # A ring of its colour over the sprite, which hides most of the disc.
            pg.draw.circle(surface, colour, centre, px * 9 // 20, width=max(2, px // 12))
            if delivered is not None and delivered[i]:
                corner = (round(col * px), round(row * px))
                pg.draw.rect(surface, DELIVERED_FRAME, (*corner, px, px), width=2 * border)
            if headings is not None:
                tip_row, tip_col = _pointer_tip(row, col, headings[i], 0.45)
                start, end = (centre, ((tip_col + 0.5) * px, (tip_row + 0.5) * px))
                pg.draw.line(surface, HEADING_POINTER, start, end, max(2, px // 10))
        return np.ascontiguousarray(pg.surfarray.pixels3d(surface).transpose(1, 0, 2))

    # ------------------------------------------------------------------- window
    def show(
        self,
        robot: Sequence[float],
        target: tuple[int, int],
        status: str = "",
        fps: float | None = None,
    ) -> bool:
        """Draw one frame in the window, paced at ``fps`` (default :attr:`render_fps`).

        Opens the window on first use. Returns ``False``, drawing nothing, once
        the user has closed the window or pressed Escape; it never exits the
        process, so a notebook kernel survives.
        """
        if self.closed_by_user:
            return False
        pg = self._ensure_pygame()
        if self._window is None or pg.display.get_surface() is not self._window:
            # First frame, or another environment's close() shut the shared display down.
            check_display()
            pg.display.init()
            check_display(pg)
            pg.display.set_caption(self.title)
            self._window = pg.display.set_mode((self.width, self.height))
            self._clock = pg.time.Clock()
        for event in pg.event.get():
            if event.type == pg.QUIT or (event.type == pg.KEYDOWN and event.key == pg.K_ESCAPE):
                self.closed_by_user = True
                self.close()
                return False
        self.draw(robot, target, status, surface=self._window)
        pg.display.flip()
        self._clock.tick(self.render_fps if fps is None else fps)
        return True

    def close(self) -> None:
        """Close the window (if any) and drop every pygame resource; safe to call twice."""
        if self._window is not None and self._pg.display.get_surface() is self._window:
            self._pg.display.quit()
        self._window = None
        self._clock = None
        self._canvas = None
        self._floor = self._robot = self._package = self._package_carried = None
        self._font = None
        self._status_cache = None

    # ------------------------------------------------------------------ helpers
    def _ensure_pygame(self) -> Any:
        self.check_frame_size()
        if self._pg is None:
            self._pg = import_pygame()
        pg = self._pg
        if self._floor is None:
            self._load_sprites()
        if not pg.font.get_init():
            # A pygame.quit() elsewhere (Gymnasium's own envs call it in close()) shut fonts down.
            pg.font.init()
            self._font = None
            self._status_cache = None
        return pg

    def _load_sprites(self) -> None:
        pg = self._pg
        px = self.cell_px

        def load(name: str) -> pygame.Surface:
            path = sprite_path(name)
            try:
                image = pg.image.load(str(path))
            except pg.error as exc:
                raise ValueError(f"sprite {path} could not be read: {exc}") from exc
            return pg.transform.smoothscale(image, (px, px))

        tile = load("floor.png")
        floor = pg.Surface((self.cols * px, self.rows * px))
        for r in range(self.rows):
            for c in range(self.cols):
                floor.blit(tile, (c * px, r * px))
        if self.shelves:
            shelf = load("shelf.png")
            for r, c in self.shelves:
                floor.blit(shelf, (c * px, r * px))
        self._floor = floor
        self._robot = load("robot.png")
        self._package = load("package.png")
        self._package_carried = pg.transform.smoothscale(self._package, (px // 2, px // 2))

    def _status_surface(self, status: str) -> pygame.Surface:
        if self._status_cache is not None and self._status_cache[0] == status:
            return self._status_cache[1]
        if self._font is None:
            self._font = self._pg.font.Font(None, self.status_px)
        text = fit_text(
            self._font.render(status, True, STATUS_TEXT), self.width - 2 * self._status_margin()
        )
        self._status_cache = (status, text)
        return text

    def _status_margin(self) -> int:
        return max(4, self.cell_px // 8)  # [px] left and right of the status text


#: Cells smaller than this [px] show a fleet's robots as discs drawn with array operations
#: (:meth:`WarehouseRenderer.fleet_rgb_array`); larger cells show the robot sprite.
FLEET_SPRITE_MIN_PX = 24


def _pointer_tip(row: float, col: float, heading: float, length: float) -> tuple[float, float]:
    """Where a pointer ``length`` cells long from ``(row, col)`` along ``heading`` ends
    [cells]."""
    angle = heading * np.pi / 2  # quarter turns clockwise from east (rows grow downwards)
    return row + np.sin(angle) * length, col + np.cos(angle) * length


__all__ = [
    "DEFAULT_CELL_PX",
    "DELIVERED_FRAME",
    "FLEET_COLOURS",
    "FLEET_SPRITE_MIN_PX",
    "HEADING_GLYPHS",
    "HEADING_POINTER",
    "MAP_DELIVERED",
    "MAP_FLOOR",
    "MAP_FRAME_WIDTH_PX",
    "MAP_PACKAGE",
    "MAP_ROBOT_COLOURS",
    "MAP_SHELF",
    "MAX_FRAME_PIXELS",
    "MAX_FRAME_SIDE_PX",
    "MIN_CELL_PX",
    "SPRITE_DIRS",
    "SPRITE_NAMES",
    "STATUS_BACKGROUND",
    "STATUS_TEXT",
    "FrameTooLargeError",
    "NoDisplayError",
    "WarehouseRenderer",
    "ansi_frame",
    "check_display",
    "fit_text",
    "fleet_ansi_frame",
    "fleet_map_frame",
    "import_pygame",
    "map_cell_px",
    "sprite_path",
]
