"""Ctrl-C while a command starts: one line and exit status 130, never a traceback.

``python -m warehouse_phys.<app>`` spends a second or more importing (the package,
numpy, pymunk, numba, ...) before its ``main`` takes charge of interrupts
(:mod:`warehouse_phys.apps.interrupts`). :class:`command_interrupts` wraps those imports:
an interrupt there ends the command with ``python -m warehouse_phys.<app>: interrupted
while starting; nothing was written`` and status 130, as an interrupt later does. Code
that imports the package for itself (a script, a notebook, a test run) gets its
``KeyboardInterrupt`` back, as ever. Imports nothing Python has not loaded at start (an
interrupt in Python's own start, before the package's first line, is beyond its reach).
"""

from __future__ import annotations

import sys

#: The exit status of a command stopped by Ctrl-C (128 + SIGINT), as the commands' own.
INTERRUPTED = 130


def started_command() -> str | None:
    """``python -m warehouse_phys.<app>`` when this process was started so (the command
    line Python was given), else ``None``."""
    argv = list(getattr(sys, "orig_argv", []))
    if "-m" not in argv[:-1]:
        return None
    module = argv[argv.index("-m") + 1]
    if module != "warehouse_phys" and not module.startswith("warehouse_phys."):
        return None
    return "python -m " + module.replace(".apps.", ".").removesuffix(".__main__")


class command_interrupts:  # a context manager, named as one
    """A ``with`` block in which a ``KeyboardInterrupt`` becomes the command's one line and
    exit status 130, when the block runs for a command: ``running`` (a command's own
    module, run as ``__main__``), or by default while Python is still locating the module
    of ``-m`` (``sys.argv[0] == "-m"``: it imports the package on the way)."""

    def __init__(self, running: bool | None = None) -> None:
        self.running = running

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: type[BaseException] | None, *rest: object) -> bool:
        if kind is None or not issubclass(kind, KeyboardInterrupt):
            return False
        command = started_command()
        starting = sys.argv[:1] == ["-m"] if self.running is None else self.running
        if command is None or not starting:
            return False  # not ours to end: the importer's interrupt
        sys.stderr.write(f"{command}: interrupted while starting; nothing was written\n")
        raise SystemExit(INTERRUPTED) from None
