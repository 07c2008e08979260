"""How a command stops on Ctrl-C and SIGTERM: as an interrupt, raised where Python code
can take it, never inside numba's compiler.

``train``, ``simulate`` and ``play`` wrap their ``main`` in :func:`stops_on_sigterm`:
SIGTERM then raises :class:`Terminated` (a ``KeyboardInterrupt``), so a command stops on
it as on Ctrl-C, with the same message and clean-up, and exits with 143 instead of 130.

An interrupt that arrives while numba compiles a kernel in the main thread is held until
the compile ends. Raised inside the compiler, it can land in one of LLVM's callbacks,
which prints and drops it (the command then runs on, with SIGTERM ignored), or leave a
half-built library that fails the compile with an unrelated ``RuntimeError``. A first
compile of the planners' kernels takes seconds, so this is not a rare window.

A few steps must not be cut in half either: creating a run folder and taking charge of
removing it again. :func:`deferred` holds an interrupt for the length of such a block.
"""

from __future__ import annotations

import contextlib
import functools
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any, ParamSpec

P = ParamSpec("P")

#: The event numba broadcasts as its compiler lock is taken and given back.
_COMPILER_LOCK_EVENT = "numba:compiler_lock"


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised as an interrupt: a command stops on it as on Ctrl-C, with the same
    message and clean-up, and exits with :func:`interruption`'s 143."""


def stops_on_sigterm(main: Callable[P, int]) -> Callable[P, int]:
    """``main`` with SIGTERM raising :class:`Terminated` while it runs (in the main thread;
    the previous handlers are put back after). A second SIGTERM during the first one's
    clean-up is ignored, so that the clean-up finishes. SIGTERM, and Ctrl-C where Python's
    own handler has it, wait for a numba compile running in the main thread to end."""

    @functools.wraps(main)
    def run(*args: P.args, **kwargs: P.kwargs) -> int:
        if threading.current_thread() is not threading.main_thread():
            return main(*args, **kwargs)  # only the main thread may set a handler
        previous = {signal.SIGTERM: signal.signal(signal.SIGTERM, _terminate)}
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            previous[signal.SIGINT] = signal.signal(signal.SIGINT, _interrupt)
        try:
            return main(*args, **kwargs)
        finally:
            for signum, handler in previous.items():
                if handler is not None:  # None: a handler set outside Python, left as it was
                    signal.signal(signum, handler)

    return run


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A block that a SIGTERM or Ctrl-C arriving in it does not cut short: the interrupt is
    held and raised as the block ends, after whatever the block raised (with the main
    thread's handlers of :func:`stops_on_sigterm`; in other threads, and under other
    handlers, the block is a plain one). Blocks may nest; the outermost raises."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _deferring.append(True)
    try:
        yield
    finally:
        _deferring.pop()
        if not _deferring and _pending:
            raise _pending.pop()


def interruption(interrupt: KeyboardInterrupt) -> tuple[str, int]:
    """What stopped a command, in a word, and its exit status: ``("terminated", 143)``
    for SIGTERM (:class:`Terminated`), ``("interrupted", 130)`` for Ctrl-C."""
    if isinstance(interrupt, Terminated):
        return "terminated", 128 + signal.SIGTERM
    return "interrupted", 128 + signal.SIGINT


def _terminate(signum: int, frame: object) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _raise_outside_compiler(Terminated())


def _interrupt(signum: int, frame: object) -> None:
    _raise_outside_compiler(KeyboardInterrupt())


def _raise_outside_compiler(interrupt: KeyboardInterrupt) -> None:
    """Raise ``interrupt`` now, or, while this thread holds numba's compiler lock, as the
    lock is given back (the first interrupt held wins; later ones add nothing). Inside a
    :func:`deferred` block it is held for the block's end instead."""
    if _deferring:
        if not _pending:
            _pending.append(interrupt)
        return
    compiler = sys.modules.get("numba.core.compiler_lock")  # numba imported: it may compile
    if compiler is None or not compiler.global_compiler_lock.is_locked():
        raise interrupt
    if not _held:
        from numba.core import event

        _held.append(_held_type()(interrupt))
        event.register(_COMPILER_LOCK_EVENT, _held[0])


#: One entry for each :func:`deferred` block the main thread is in.
_deferring: list[bool] = []
#: The interrupt held until the outermost :func:`deferred` block ends (at most one).
_pending: list[KeyboardInterrupt] = []

#: The interrupt held until the compile ends, as its numba listener (at most one).
_held: list[Any] = []


@functools.cache
def _held_type() -> type:
    """The numba listener that raises a held interrupt once the compiler lock is free
    (defined on first use, so that a command that never compiles never imports numba)."""
    from numba.core import compiler_lock, event

    class HeldInterrupt(event.Listener):
        def __init__(self, interrupt: KeyboardInterrupt) -> None:
            self.interrupt = interrupt

        def on_start(self, _: object) -> None:
            pass

        def on_end(self, _: object) -> None:
            main = threading.current_thread() is threading.main_thread()
            if main and not compiler_lock.global_compiler_lock.is_locked():  # outermost
                event.unregister(_COMPILER_LOCK_EVENT, self)
                _held.clear()
                raise self.interrupt

    return HeldInterrupt
