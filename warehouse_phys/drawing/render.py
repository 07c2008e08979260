"""Drawing the warehouse: one renderer for every environment of the package.

The renderer knows nothing about episodes or physics. It draws a floor of
``rows`` x ``cols`` tiles, the package on its cell, the robot at a *continuous*
position in cell units and a status line under the grid. Positions are
``(row, col)`` floats in which whole numbers are cell centres, so ``(0.5, 1.0)``
is half-way between the centres of cells (0, 1) and (1, 1).

pygame is imported only when a picture is first drawn: an environment made
with ``render_mode=None`` (or ``"ansi"``) never loads it.

Its length is the one place the package draws: the pygame renderer, the array-drawn
maps of large fleets and the text frames.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Collection, Iterable, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

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
DELIVERED_FRAME = (90, 200, 90)  # RGB: around the cell where the package was delivered
STATUS_TEXT = (235, 235, 235)  # RGB
#: A turning robot's heading in text frames: east, south, west, north.
HEADING_GLYPHS = ">v<^"
#: The pointer that shows a turning robot's heading in pictures.
HEADING_POINTER = (20, 20, 24)  # RGB


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


def ansi_frame(
    rows: int,
    cols: int,
    robot: tuple[int, int],
    target: tuple[int, int],
    shelves: Collection[tuple[int, int]] = (),
) -> str:
    """The console picture: one line per grid row, each cell as a symbol and a space.

    ``R`` robot, ``T`` target, ``#`` shelf, ``_`` floor. The robot is drawn
    over the target when both share a cell.
    """
    lines = []
    for r in range(rows):
        cells = []
        for c in range(cols):
            if (r, c) == (robot[0], robot[1]):
                cells.append("R ")
            elif (r, c) == (target[0], target[1]):
                cells.append("T ")
            elif (r, c) in shelves:
                cells.append("# ")
            else:
                cells.append("_ ")
        lines.append("".join(cells) + "\n")
    return "".join(lines)


def fleet_ansi_frame(
    rows: int,
    cols: int,
    robots: Sequence[Sequence[int]],
    packages: Sequence[Sequence[int]],
    shown: Sequence[bool],
    shelves: Collection[tuple[int, int]] = (),
    *,
    headings: Sequence[int] | None = None,
) -> str:
    """A fleet's console picture: one line per grid row, cells separated by spaces.

    Robot ``i`` (at ``robots[i]``) is the digit ``i % 10``, its package (at
    ``packages[i]``) the letter ``"a"`` + ``i % 26``, drawn only where
    ``shown[i]`` (a robot on the floor); ``#`` shelf, ``_`` floor. Robots are
    drawn over packages. With ``headings`` (turning robots, 0..3 east, south, west,
    north) each robot's heading stands right after its digit, in place of the space:
    :data:`HEADING_GLYPHS` (``>``, ``v``, ``<``, ``^``).
    """
    board = [["#" if (r, c) in shelves else "_" for c in range(cols)] for r in range(rows)]
    after = [[" "] * cols for _ in range(rows)]
    for i, (row, col) in enumerate(packages):
        if shown[i]:
            board[row][col] = chr(ord("a") + i % 26)
    for i, (row, col) in enumerate(robots):
        if shown[i]:
            board[row][col] = str(i % 10)
            if headings is not None:
                after[row][col] = HEADING_GLYPHS[headings[i] % 4]
    if headings is None:
        return "\n".join(" ".join(line) for line in board)
    return "\n".join(
        "".join(a + b for a, b in zip(line, tail, strict=True)).rstrip()
        for line, tail in zip(board, after, strict=True)
    )


def import_pygame() -> ModuleType:
    """Import pygame (the ``pygame-ce`` distribution) quietly, or say how to install it."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:  # pragma: no cover - pygame-ce is a runtime dependency
        raise ImportError(
            "rendering needs pygame; install it with `pip install pygame-ce`"
        ) from exc
    return pygame


class NoDisplayError(RuntimeError):
    """There is no display to open a window on; the message says how to get one."""


#: SDL's video drivers that draw nowhere a person can see.
_INVISIBLE_DRIVERS = ("offscreen", "dummy", "evdev")
_NO_DISPLAY_HELP = (
    "run it in a desktop session, forward one with `ssh -X`, or start a virtual one "
    "with `xvfb-run`; rgb_array rendering needs no display"
)


def check_display(pg: ModuleType | None = None) -> None:
    """Refuse to open a window that nobody could see.

    With no ``DISPLAY`` or ``WAYLAND_DISPLAY`` on Linux and the BSDs, SDL falls
    back to its off-screen driver and a window would silently go nowhere. Given
    ``pg`` (pygame with its display initialised), the driver SDL picked is
    checked too. Setting ``SDL_VIDEODRIVER`` (``dummy`` in tests, say) is taken
    as the user's choice and always allowed.

    Raises:
        NoDisplayError: saying there is no display and how to get one.
    """
    if os.environ.get("SDL_VIDEODRIVER"):
        return
    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise NoDisplayError(
            f"cannot open a window: there is no display (DISPLAY and WAYLAND_DISPLAY are "
            f"unset); {_NO_DISPLAY_HELP}"
        )
    if pg is not None and pg.display.get_init():
        driver = pg.display.get_driver()
        if driver in _INVISIBLE_DRIVERS:
            raise NoDisplayError(
                f"cannot open a window: SDL found no display and chose its {driver!r} "
                f"driver, which shows nothing; {_NO_DISPLAY_HELP}"
            )


def fit_text(text: pygame.Surface, width: int) -> pygame.Surface:
    """``text`` (a rendered line), shrunk to ``width`` pixels if it is wider: narrow
    windows show the whole line, smaller, rather than clip it."""
    if text.get_width() <= width:
        return text
    pg = import_pygame()
    height = max(1, text.get_height() * width // text.get_width())
    return pg.transform.smoothscale(text, (width, height))


#: The colours of a fleet's robots and their packages, robot by robot (RGB).
#: A fleet's robot colours, robot ``i`` in ``FLEET_COLOURS[i % 8]`` [RGB]: Okabe and Ito's
#: palette, which colour-blind eyes tell apart (vermillion first: robot 0 is the one a
#: person drives in ``play``), with a violet for its black, which would pass for a shelf.
#: None is close to the floor's light tiles or the shelves' dark grey.
FLEET_COLOURS: tuple[tuple[int, int, int], ...] = (
    (213, 94, 0),
    (0, 114, 178),
    (0, 158, 115),
    (230, 159, 0),
    (204, 121, 167),
    (86, 180, 233),
    (240, 228, 66),
    (120, 94, 240),
)


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
        self.render_fps = render_fps
        self.title = title
        self.status_px = max(20, self.cell_px * 3 // 8)  # [px] height of the status line
        self.width = cols * self.cell_px
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
            _stamp_fleet(frame, px, border, robots, packages, delivered)
            if headings is not None:
                _stamp_headings(frame, px, robots, headings)
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


#: Robot colours for map frames: :data:`FLEET_COLOURS` as an array [RGB].
MAP_ROBOT_COLOURS = np.array(FLEET_COLOURS, dtype=np.uint8)
MAP_FLOOR = (245, 245, 240)  # RGB
#: Shelves in a light grey, so that the near-black packages stand out from them even
#: at 1 or 2 pixels a cell; every robot colour stays far from both.
MAP_SHELF = (185, 185, 195)  # RGB
MAP_PACKAGE = (25, 25, 25)  # RGB: a dark dot, left visible in a robot standing on it
MAP_DELIVERED = DELIVERED_FRAME  # RGB: a parked robot that delivered
#: Cells smaller than this [px] show a fleet's robots as discs drawn with array operations
#: (:meth:`WarehouseRenderer.fleet_rgb_array`); larger cells show the robot sprite.
FLEET_SPRITE_MIN_PX = 24
#: Widest map frame drawn by :func:`fleet_map_frame` when it chooses the cell size [px].
MAP_FRAME_WIDTH_PX = 1000


def _stamp(
    frame: np.ndarray, tops: np.ndarray, lefts: np.ndarray, mask: np.ndarray, colours: Any
) -> None:
    """Paint ``mask`` (a ``(px, px)`` bool array) at each ``(tops[i], lefts[i])`` of
    ``frame`` in ``colours[i]`` (or one colour for all), with array operations."""
    ys, xs = np.nonzero(mask)
    colours = np.asarray(colours, dtype=np.uint8).reshape(-1, 3)
    frame[tops[:, None] + ys, lefts[:, None] + xs] = colours[:, None, :]


def _stamp_fleet(
    frame: np.ndarray,
    px: int,
    border: int,
    robots: Sequence[Sequence[float]],
    packages: Sequence[tuple[int, int]],
    delivered: Sequence[bool] | None,
) -> None:
    """A fleet's packages (dark squares framed ``border`` px wide in their robot's colour),
    robots (discs of their colour; a package's frame shows round a robot standing on it)
    and green frames round the delivered robots, painted onto ``frame``."""
    n = len(robots)
    if n == 0:
        return
    colours = MAP_ROBOT_COLOURS[np.arange(n) % len(MAP_ROBOT_COLOURS)]
    centre = (np.arange(px) + 0.5 - px / 2) ** 2
    disc = centre[:, None] + centre[None, :] <= (px * 9 / 20) ** 2
    ring = np.ones((px, px), dtype=bool)
    ring[border:-border, border:-border] = False
    inner = np.zeros((px, px), dtype=bool)
    inner[px // 3 : px - px // 3, px // 3 : px - px // 3] = True
    cells = np.asarray(packages, dtype=np.int64).reshape(-1, 2) * px
    _stamp(frame, cells[:, 0], cells[:, 1], inner, MAP_PACKAGE)
    _stamp(frame, cells[:, 0], cells[:, 1], ring, colours[: len(cells)])
    corners = np.rint(np.asarray(robots, dtype=np.float64).reshape(-1, 2) * px).astype(np.int64)
    _stamp(frame, corners[:, 0], corners[:, 1], disc, colours)
    if delivered is not None:
        done = np.asarray(delivered, dtype=bool)
        _stamp(frame, corners[done, 0], corners[done, 1], ring, DELIVERED_FRAME)


def _pointer_tip(row: float, col: float, heading: float, length: float) -> tuple[float, float]:
    """Where a pointer ``length`` cells long from ``(row, col)`` along ``heading`` ends
    [cells]."""
    angle = heading * np.pi / 2  # quarter turns clockwise from east (rows grow downwards)
    return row + np.sin(angle) * length, col + np.cos(angle) * length


def _stamp_headings(
    frame: np.ndarray, px: int, robots: Sequence[Sequence[float]], headings: Sequence[float]
) -> None:
    """Each robot's heading as a dark square between its centre and its rim (cells of
    ``px`` pixels, robots at cell positions), painted with array operations."""
    size = max(1, px // 4)
    angle = np.asarray(headings, dtype=np.float64) * np.pi / 2
    at = np.asarray(robots, dtype=np.float64).reshape(-1, 2) + 0.5
    reach = (px * 9 / 20 - size / 2) / px  # [cells] from the centre
    middle = (at + reach * np.stack([np.sin(angle), np.cos(angle)], axis=1)) * px
    corner = np.rint(middle - size / 2).astype(np.int64)
    limit = np.array(frame.shape[:2]) - size
    corner = np.clip(corner, 0, limit)
    _stamp(frame, corner[:, 0], corner[:, 1], np.ones((size, size), dtype=bool), HEADING_POINTER)


def map_cell_px(rows: int, cols: int, width_px: int = MAP_FRAME_WIDTH_PX) -> int:
    """The cell size [px] that fits the longer side of a ``rows`` x ``cols`` floor in
    ``width_px`` (at least 1, at most 24): 2 px for the 500 x 140 warehouse."""
    return int(np.clip(width_px // max(rows, cols), 1, 24))


@functools.lru_cache(maxsize=4)  # a few floors: a run and its baselines share one
def _floor_image(rows: int, cols: int, px: int, packed_shelves: bytes) -> np.ndarray:
    """The floor and its shelves (``packed_shelves``: the shelf mask through
    ``np.packbits``) at ``px`` pixels a cell, read-only. Cached by content: a large map's
    tens of thousands of shelves are painted once, not on every frame."""
    packed = np.frombuffer(packed_shelves, dtype=np.uint8)
    shelves = np.unpackbits(packed, count=rows * cols).reshape(rows, cols).astype(bool)
    cells = np.empty((rows, cols, 3), dtype=np.uint8)
    cells[:] = MAP_FLOOR
    cells[shelves] = MAP_SHELF
    image = np.repeat(np.repeat(cells, px, axis=0), px, axis=1)
    image.flags.writeable = False
    return image


def _shelf_mask(grid: Any) -> np.ndarray:
    """``grid``'s shelves as a ``(rows, cols)`` boolean array: a
    :class:`~warehouse_phys.world.grid.WarehouseGrid`'s own ``shelf_mask``, else built
    from ``grid.shelves`` (any collection of cells)."""
    mask = getattr(grid, "shelf_mask", None)
    if mask is not None:
        return np.asarray(mask, dtype=bool)
    mask = np.zeros((grid.rows, grid.cols), dtype=bool)
    cells = np.array(list(grid.shelves), dtype=np.int64).reshape(-1, 2)
    mask[cells[:, 0], cells[:, 1]] = True
    return mask


def fleet_map_frame(
    grid: Any,
    robots: np.ndarray,
    packages: np.ndarray,
    *,
    parked: np.ndarray | None = None,
    on_floor: np.ndarray | None = None,
    cell_px: int | None = None,
    headings: np.ndarray | None = None,
) -> np.ndarray:
    """A fleet on a large floor as an ``(H, W, 3)`` uint8 map, drawn with array operations
    (no pygame, no sprites: one pass however many robots): the floor light, shelves light
    grey, packages near-black, robot ``i`` a square in ``MAP_ROBOT_COLOURS[i % 8]``.

    A parked robot (it delivered) is framed in green, as the single robot's delivery is,
    keeping its colour inside, when a cell is 4 px or more; on smaller cells it is a
    green square. Where a robot stands on its or another's package and the cell is 3 px
    or more, the package shows as a dark square in the robot's middle. Robots that left
    the floor are not drawn. ``cell_px`` defaults to :func:`map_cell_px`. With
    ``headings`` (turning robots, 0..3) each robot's cell shows its heading as a dark
    mark on the side it faces, on cells of 3 px or more (a 1- or 2-pixel cell has no
    side to mark).

    The floor and its shelves are drawn once per floor and cell size and copied: a
    frame costs a copy of the picture and work in proportion to the robots, however
    many shelves the floor has.

    Raises:
        ValueError: if ``cell_px`` is below 1.
    """
    rows, cols = grid.rows, grid.cols
    px = map_cell_px(rows, cols) if cell_px is None else int(cell_px)
    if px < 1:
        raise ValueError(f"cell_px must be at least 1, got {cell_px}")
    robots = np.asarray(robots, dtype=np.int64).reshape(-1, 2)
    packages = np.asarray(packages, dtype=np.int64).reshape(-1, 2)
    n = len(robots)
    shown = np.ones(n, dtype=bool) if on_floor is None else np.asarray(on_floor, dtype=bool)
    done = np.zeros(n, dtype=bool) if parked is None else np.asarray(parked, dtype=bool)
    waiting = shown & ~done  # robots whose package is still on the floor
    framed = px >= 4  # a parked robot keeps its colour inside a green frame
    frame = _floor_image(rows, cols, px, np.packbits(_shelf_mask(grid)).tobytes()).copy()
    # Cell (r, c) is blocks[r, :, c, :]: one fancy index paints a whole cell per robot.
    blocks = frame.reshape(rows, px, cols, px, 3)
    blocks[packages[waiting, 0], :, packages[waiting, 1], :] = MAP_PACKAGE
    colours = MAP_ROBOT_COLOURS[np.arange(n) % len(MAP_ROBOT_COLOURS)]
    if not framed:
        colours[done] = MAP_DELIVERED
    at = robots[shown]
    blocks[at[:, 0], :, at[:, 1], :] = colours[shown][:, None, None, :]
    if framed:  # a green frame round each parked robot's cell
        r, c = robots[shown & done].T
        border = max(1, px // 6)
        for side in (slice(0, border), slice(px - border, px)):
            blocks[r, side, c, :] = MAP_DELIVERED
            blocks[r, :, c, side] = MAP_DELIVERED
    if px >= 3:  # packages under robots: a square in the middle of the robot's cell
        occupied = np.zeros((rows, cols), dtype=bool)
        occupied[at[:, 0], at[:, 1]] = True
        under = packages[waiting][occupied[packages[waiting, 0], packages[waiting, 1]]]
        middle = slice(px // 3, px - px // 3)
        blocks[under[:, 0], middle, under[:, 1], middle] = MAP_PACKAGE
    if headings is not None and px >= 3:
        on = at.astype(np.float64)
        _stamp_headings(frame, px, on, np.asarray(headings, dtype=np.float64)[shown])
    return frame
