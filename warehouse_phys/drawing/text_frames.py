"""Text frames of a floor: the console pictures of the ``ansi`` render mode.

One line per grid row, one symbol per cell: a single robot and its target
(:func:`ansi_frame`), or a fleet's robots, packages and, for turning robots, headings
(:func:`fleet_ansi_frame`). Plain strings: no pygame, no numpy.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

#: A turning robot's heading in text frames: east, south, west, north.
HEADING_GLYPHS = ">v<^"


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
