"""Ctrl-C while a command starts: one line and exit status 130, never a traceback.

``python -m warehouse_phys.<app>`` spends a second or more importing (the package,
numpy, pymunk, numba, ...) before its ``main`` takes charge of interrupts
(:mod:`warehouse_phys.apps.interrupts`). :class:`command_interrupts` wraps those imports:
an interrupt there ends the command with ``python -m warehouse_phys.<app>: interrupted
while starting; nothing was written`` and status 130, as an interrupt later does. Code
that imports the package for itself (a script, a notebook, a test run) gets its
``KeyboardInterrupt`` back, as ever. Each command's module wraps its own imports too, for
the long names (``python -m warehouse_phys.apps.<app>``), which import it outside the
package's block. Imports nothing Python has not loaded at start (an
interrupt in Python's own start, before the package's first line, is beyond its reach).

While a command imports, Ctrl-C is *held*: Python's handler is replaced by one that notes
the interrupt, and the block ends the command when its imports are done (at most a second
or two later). An interrupt raised inside a compiled extension's start does not always
come back as ``KeyboardInterrupt``: numba's prints the interrupt's traceback itself and
fails with ``ImportError: numba._devicearray failed to import``. Held, it never lands
there.

Python ignores an interrupt that lands in a callback it runs itself (the import system's
module-lock callbacks, say), printing ``Exception ignored in ...`` and a traceback, and
goes on. A command's process passes such an interrupt on to its main thread instead
(:func:`pass_on_ignored_interrupts`), where the command's own handling ends it in one line.
"""

from __future__ import annotations

import _signal
import _thread
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


def pass_on_ignored_interrupts() -> None:
    """From now on, a ``KeyboardInterrupt`` that Python would ignore (raised in a callback
    it runs itself: ``sys.unraisablehook``) is raised again in the main thread, silently;
    anything else goes to the hook there was. Once per process; a command's (the module)."""
    if getattr(sys.unraisablehook, "_passes_on_interrupts", False):
        return
    previous = sys.unraisablehook

    def hook(unraisable: object) -> None:
        if isinstance(getattr(unraisable, "exc_value", None), KeyboardInterrupt):
            # As if Ctrl-C came again, from another thread: raised in this hook, Python
            # would ignore it once more. At interpreter shutdown no thread starts, and
            # the command is ending anyway (not contextlib.suppress: see the module).
            try:  # noqa: SIM105
                _thread.start_new_thread(_thread.interrupt_main, ())
            except RuntimeError:
                pass
            return
        previous(unraisable)  # type: ignore[arg-type]

    hook._passes_on_interrupts = True  # type: ignore[attr-defined]
    sys.unraisablehook = hook


class command_interrupts:  # a context manager, named as one
    """A ``with`` block in which Ctrl-C becomes the command's one line and exit status 130,
    when the block runs for a command: ``running`` (a command's own module, run as
    ``__main__``), or by default while Python is still locating the module of ``-m``
    (``sys.argv[0] == "-m"``: it imports the package on the way). For a command the
    interrupt is held to the block's end (see the module); elsewhere the block changes
    nothing."""

    def __init__(self, running: bool | None = None) -> None:
        self.running = running
        self._previous: object = None
        self._held = False

    def _ours(self) -> str | None:
        """The command this block starts, or None (not a command's start)."""
        command = started_command()
        starting = sys.argv[:1] == ["-m"] if self.running is None else self.running
        return command if starting else None

    def _hold(self, signum: int, frame: object) -> None:
        self._held = True

    def __enter__(self) -> None:
        if started_command() is not None:
            pass_on_ignored_interrupts()
        if self._ours() is None or _signal.getsignal(_signal.SIGINT) is not (
            _signal.default_int_handler
        ):
            return  # not a command's start, or Ctrl-C is not Python's to raise here
        try:
            self._previous = _signal.signal(_signal.SIGINT, self._hold)
        except ValueError:  # not the main thread: signals are the main thread's
            self._previous = None

    def __exit__(self, kind: type[BaseException] | None, *rest: object) -> bool:
        if self._previous is not None:
            _signal.signal(_signal.SIGINT, self._previous)
            self._previous = None
        interrupted = kind is not None and issubclass(kind, KeyboardInterrupt)
        command = self._ours()
        if command is None or not (interrupted or self._held):
            return False  # not ours to end: the importer's interrupt, or none
        sys.stderr.write(f"{command}: interrupted while starting; nothing was written\n")
        raise SystemExit(INTERRUPTED) from None
