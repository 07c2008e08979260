"""What the package's command lines share: usage errors, argument types, the floor to use.

``python -m warehouse_phys.train`` and ``python -m warehouse_phys.play`` both
pick an environment with ``--env grid|phys`` and a floor with ``--rows``,
``--cols`` or ``--layout``; this module parses those the same way for both. Every
command prints a warning as one line (:func:`warnings_in_one_line`).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, ParamSpec

from warehouse_phys.apps.interrupts import deferred
from warehouse_phys.apps.runs import ENVIRONMENTS, Floor
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layout_text import MAX_SIDE, MIN_SIDE
from warehouse_phys.world.layouts import FLEET_PRESETS, PRESETS, read_movingai
from warehouse_phys.world.maps import MAPS, map_path

if TYPE_CHECKING:
    from warehouse_phys.files.runfolder import RunFolder

P = ParamSpec("P")

DEFAULT_ENV = "phys"
#: Most robots a command takes; the floor may allow fewer (a clear error says so).
MAX_CLI_ROBOTS = 10_000


class UsageError(Exception):
    """A bad command line or input file: reported in one line, exit status 2."""


def written_note(folder: RunFolder | None) -> str:
    """What a run that stopped early left in its run folder ``folder``, in words."""
    if folder is None or not folder.written:
        return "nothing was written"
    names = ", ".join(folder.written)
    return f"{names} {'is' if len(folder.written) == 1 else 'are'} complete in {folder.path}"


def warnings_in_one_line(prog: str) -> Callable[[Callable[P, int]], Callable[P, int]]:
    """A command's ``main`` whose warnings print as one line each on stderr,
    ``<prog>: warning: <message>`` (its first line), rather than Python's two (where the
    warning was raised, and that line's source). Which warnings show is left to the
    warning filters (``python -W``), as ever."""

    def one_line(main: Callable[P, int]) -> Callable[P, int]:
        @functools.wraps(main)
        def run(*args: P.args, **kwargs: P.kwargs) -> int:
            with warnings.catch_warnings():  # the way warnings show is put back after
                warnings.showwarning = functools.partial(_show_warning, prog)
                return main(*args, **kwargs)

        return run

    return one_line


def _show_warning(
    prog: str,
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    text = str(message).strip().splitlines() or [category.__name__]
    print(f"{prog}: warning: {text[0]}", file=sys.stderr if file is None else file)


class ArgumentParser(argparse.ArgumentParser):
    """An ``argparse`` parser that raises :class:`UsageError` instead of exiting."""

    def error(self, message: str) -> NoReturn:
        """Raise :class:`UsageError` with ``message`` (argparse's own prints it and exits)."""
        raise UsageError(message)


#: Largest integer a command-line option takes when it names no maximum of its own: a
#: 64-bit integer (the numpy arrays and generators downstream hold no more).
MAX_OPTION_INT = 2**63 - 1


def bounded_int(minimum: int, what: str, maximum: int | None = None) -> Any:
    """An argument type: an integer of at least ``minimum`` and at most ``maximum``
    (default :data:`MAX_OPTION_INT`), described as ``what`` in errors; an integer too long
    to show is described by its number of digits."""
    top = MAX_OPTION_INT if maximum is None else maximum

    def parse(text: str) -> int:
        digits = text.strip().lstrip("+-")
        if digits.isdigit() and len(digits) > 30:  # never echoed, nor made an int past 4,300
            limit = "" if maximum is not None else f" (at most {MAX_OPTION_INT:,})"
            raise argparse.ArgumentTypeError(
                f"expected {what}{limit}, got an integer of {len(digits):,} digits"
            )
        try:
            value = int(text)
        except ValueError:
            shown = text if len(text) <= 40 else f"{text[:40]}..."
            raise argparse.ArgumentTypeError(f"expected {what}, got {shown!r}") from None
        if value < minimum or value > top:
            limit = "" if maximum is not None or value < minimum else f" (at most {top:,})"
            raise argparse.ArgumentTypeError(f"expected {what}{limit}, got {value}")
        return value

    return parse


def guidance_fields(text: str) -> dict[str, Any]:
    """An argument type: a JSON object of a guided planner's fields (those of
    :class:`~warehouse_phys.planners.guidance_config.GuidanceConfig`, and a repairing
    planner's repair), such as ``{"reroute": 32}``
    (:func:`~warehouse_phys.planners.named.guidance_from_json`)."""
    # Here, not at the top: every command imports this module, few need the planners.
    from warehouse_phys.planners.named import guidance_from_json

    try:
        return guidance_from_json(text)
    except ValueError:
        shown = text if len(text) <= 40 else f"{text[:40]}..."
        raise argparse.ArgumentTypeError(
            f"expected a JSON object of planner fields, such as '{{\"reroute\": 32}}', "
            f"got {shown!r}"
        ) from None


def add_guidance_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--guidance JSON`` (:func:`guidance_fields`; default ``{}``, the defaults)."""
    parser.add_argument(
        "--guidance", type=guidance_fields, default={}, metavar="JSON",
        help="the guided planners' fields, a JSON object: GuidanceConfig's (such as "
        "'{\"reroute\": 32}') and the repair's (neighbourhood, iterations, repair_time_limit)",
    )  # fmt: skip


def add_env_argument(parser: argparse.ArgumentParser, *, default: str | None, note: str) -> None:
    """Add ``--env grid|phys``; ``note`` ends its help, after the default's id."""
    parser.add_argument(
        "--env",
        choices=sorted(ENVIRONMENTS),
        default=default,
        help=f"environment: phys ({ENVIRONMENTS['phys']}) or grid ({ENVIRONMENTS['grid']}); "
        f"default {DEFAULT_ENV}{note}",
    )


def add_robots_argument(parser: argparse.ArgumentParser, *, what: str) -> None:
    """``--robots N``, 1 (the single robot, the default) to :data:`MAX_CLI_ROBOTS`; ``what`` says
    what a fleet does in this command."""
    parser.add_argument(
        "--robots",
        type=bounded_int(1, f"a number of robots from 1 to {MAX_CLI_ROBOTS:,}", MAX_CLI_ROBOTS),
        default=1,
        help=f"{what} (default 1, the single robot)",
    )


def add_floor_arguments(parser: argparse.ArgumentParser, *, table_note: str = "") -> None:
    """Add ``--rows``, ``--cols`` and ``--layout``, read back by :func:`floor_from_args`."""
    parser.add_argument(
        "--rows",
        type=bounded_int(MIN_SIDE, f"{MIN_SIDE} to {MAX_SIDE} rows", MAX_SIDE),
        help=f"grid rows, {MIN_SIDE} to {MAX_SIDE} (default 4{table_note})",
    )
    parser.add_argument(
        "--cols",
        type=bounded_int(MIN_SIDE, f"{MIN_SIDE} to {MAX_SIDE} columns", MAX_SIDE),
        help=f"grid columns, {MIN_SIDE} to {MAX_SIDE} (default 5{table_note})",
    )
    parser.add_argument(
        "--max-steps",
        type=bounded_int(1, "a positive number of steps"),
        metavar="N",
        help="time limit of an episode (default: the floor's suggested limit, "
        "200 on the default floor)",
    )
    parser.add_argument(
        "--layout",
        metavar="NAME_OR_FILE",
        help=f"a warehouse layout: a preset ({', '.join([*PRESETS, *FLEET_PRESETS])}), a "
        f"benchmark map the package ships ({', '.join(MAPS)}), a MovingAI .map file or a "
        "text file of rows ('.' floor, '#' shelf, 'P' package cell, 'S' start)",
    )


def floor_from_args(args: argparse.Namespace) -> Floor:
    """The :class:`Floor` that ``--rows``, ``--cols``, ``--layout`` and ``--max-steps`` ask for.

    Raises:
        UsageError: for ``--layout`` with ``--rows`` or ``--cols``, an unknown
            preset, or a layout file that cannot be read or is not a valid layout.
    """
    max_steps = getattr(args, "max_steps", None)
    if args.layout is None:
        return Floor(rows=args.rows, cols=args.cols, max_steps=max_steps)
    if args.rows is not None or args.cols is not None:
        raise UsageError("--rows and --cols come from the layout; leave them out with --layout")
    return floor_from_layout(args.layout, max_steps=max_steps)


def floor_from_layout(name_or_file: str, *, max_steps: int | None = None) -> Floor:
    """The :class:`Floor` of a layout preset's name, a shipped benchmark map's name
    (:data:`~warehouse_phys.world.maps.MAPS`), a MovingAI map file or a layout text file.

    Raises:
        UsageError: for an unknown preset, or a file that cannot be read or is
            not a valid layout.
    """
    if name_or_file in PRESETS:
        return Floor(preset=name_or_file, label=name_or_file, max_steps=max_steps)
    if name_or_file in FLEET_PRESETS:
        layout = FLEET_PRESETS[name_or_file]
        return Floor(layout=layout, label=name_or_file, max_steps=max_steps)
    path = map_path(name_or_file) if name_or_file in MAPS else Path(name_or_file)
    if path.suffix == ".map":  # a MovingAI benchmark map
        try:
            grid = read_movingai(path)
        except ValueError as error:
            raise UsageError(f"--layout {error}") from None
        return Floor(layout=grid.layout, label=path.stem, max_steps=max_steps)
    if not path.is_file():
        raise UsageError(
            f"--layout {name_or_file!r} is neither a preset "
            f"({', '.join([*PRESETS, *FLEET_PRESETS])}), a shipped map ({', '.join(MAPS)}) "
            "nor a file"
        )
    try:
        lines = [line.rstrip() for line in path.read_text(encoding="utf-8").splitlines()]
    except (OSError, UnicodeDecodeError) as error:
        raise UsageError(f"--layout {path}: cannot be read ({error})") from None
    while lines and not lines[-1]:
        lines.pop()
    while lines and not lines[0]:
        lines.pop(0)
    try:
        WarehouseGrid.from_layout(lines)
    except (TypeError, ValueError) as error:
        raise UsageError(f"--layout {path}: {error}") from None
    return Floor(layout=tuple(lines), label=path.stem, max_steps=max_steps)


@contextlib.contextmanager
def opened_run_folder(
    out: Path | None, new: Path, files: Sequence[str], *, overwrite: bool
) -> Iterator[RunFolder]:
    """The run folder of a command, open for the ``with`` block: ``out`` (``--out``; an
    earlier run's ``files`` in it are replaced only with ``overwrite``), or else the new
    folder ``new``. It is closed as the block ends; when the block raises (an interrupt
    included), a folder this run created and wrote nothing into is removed, with the
    parents it created for it while they are empty (``runs/`` on a first run). The folder is
    created and taken charge of with interrupts deferred
    (:func:`~warehouse_phys.apps.interrupts.deferred`), so that a SIGTERM or Ctrl-C at
    that moment cannot leave an empty folder behind.

    Raises:
        UsageError: if the folder cannot be used, the message beginning with ``--out``
            when ``out`` was given.
    """
    from warehouse_phys.files.runfolder import RunFolder, RunFolderError

    folder = (
        RunFolder(new, files, new=True)
        if out is None
        else RunFolder(out, files, overwrite=overwrite)
    )
    try:
        with deferred():
            try:
                folder.open()
            except RunFolderError as error:
                raise UsageError(f"--out {error}" if out is not None else str(error)) from None
        yield folder
    except BaseException:
        folder.close(remove_if_empty=True)
        raise
    folder.close()
