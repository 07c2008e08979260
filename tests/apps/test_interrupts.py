"""Interrupts raised where a command can take them: SIGTERM as :class:`Terminated` while a
command runs, and Ctrl-C or SIGTERM held while numba compiles in the main thread."""

import signal
import threading

import numba
import pytest
from numba.core import event

from warehouse_phys.apps import interrupts

needs_main_thread = pytest.mark.skipif(
    threading.current_thread() is not threading.main_thread(),
    reason="only the main thread receives signals; these tests send them to themselves",
)


@needs_main_thread
def test_the_sigterm_handler_lives_only_while_a_command_runs():
    seen = []

    @interrupts.stops_on_sigterm
    def command() -> int:
        seen.append(signal.getsignal(signal.SIGTERM))
        signal.raise_signal(signal.SIGTERM)
        return 0  # never reached: the signal raises

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(interrupts.Terminated) as stopped:
        command()
    assert len(seen) == 1
    assert seen[0] is not before
    assert signal.getsignal(signal.SIGTERM) is before
    assert interrupts.interruption(stopped.value) == ("terminated", 143)
    assert interrupts.interruption(KeyboardInterrupt()) == ("interrupted", 130)


#: The functions compiled here, kept for the session: numba leaves dead weak proxies behind
#: when a compiled function is freed, and a test that looks over every object then fails.
COMPILED: list[object] = []


class SignalOnCompile(event.Listener):
    """Sends ``signum`` to this process as numba starts a compile (inside its compiler
    lock), as a signal arriving in the middle of a first run's kernel compile."""

    def __init__(self, signum: int) -> None:
        self.signum = signum

    def on_start(self, _: object) -> None:
        signal.raise_signal(self.signum)

    def on_end(self, _: object) -> None:
        pass


@needs_main_thread
@pytest.mark.parametrize(
    ("signum", "raised"),
    [(signal.SIGTERM, interrupts.Terminated), (signal.SIGINT, KeyboardInterrupt)],
)
def test_a_signal_during_a_numba_compile_is_raised_once_the_compile_has_finished(signum, raised):
    if (
        signum == signal.SIGINT
        and signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        pytest.skip("Ctrl-C is held only where Python's own handler has it")

    @numba.njit
    def add_one(x):
        return x + 1

    COMPILED.append(add_one)  # freed, it would leave dead weak proxies among gc's objects

    @interrupts.stops_on_sigterm
    def command() -> int:
        with event.install_listener("numba:compile", SignalOnCompile(signum)):
            add_one(1)
        return 0  # never reached: the held signal raises as the compile ends

    before = signal.getsignal(signum)
    with pytest.raises(raised):
        command()
    assert len(add_one.signatures) == 1  # compiled whole before the interrupt was raised
    assert add_one(1) == 2
    assert interrupts._held == []  # nothing left waiting for the next compile
    assert signal.getsignal(signum) is before
    add_one(2.5)  # a later compile runs through
    assert len(add_one.signatures) == 2


@needs_main_thread
def test_a_signal_outside_a_compile_is_raised_at_once_even_after_numba_is_imported():
    ran = []

    @interrupts.stops_on_sigterm
    def command() -> int:
        signal.raise_signal(signal.SIGTERM)
        ran.append("after")
        return 0

    with pytest.raises(interrupts.Terminated):
        command()
    assert ran == []


@needs_main_thread
def test_a_signal_in_a_deferred_block_is_raised_as_the_outermost_block_ends():
    ran = []

    @interrupts.stops_on_sigterm
    def command() -> int:
        with interrupts.deferred():
            with interrupts.deferred():
                signal.raise_signal(signal.SIGTERM)
                signal.raise_signal(signal.SIGINT)  # a second interrupt adds nothing
                ran.append("inner")
            ran.append("outer")
        ran.append("after")
        return 0

    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("Ctrl-C reaches the command's handler only where Python's own has it")
    with pytest.raises(interrupts.Terminated):
        command()
    assert ran == ["inner", "outer"]
    assert interrupts._deferring == []
    assert interrupts._pending == []


@needs_main_thread
def test_a_signal_in_a_deferred_block_that_raises_is_raised_after_the_block_error():
    @interrupts.stops_on_sigterm
    def command() -> int:
        with interrupts.deferred():
            signal.raise_signal(signal.SIGTERM)
            raise OSError("the block's own error")

    with pytest.raises(interrupts.Terminated) as stopped:
        command()
    assert isinstance(stopped.value.__context__, OSError)
    assert interrupts._deferring == []
    assert interrupts._pending == []


def test_a_deferred_block_without_a_signal_is_a_plain_block():
    with interrupts.deferred():
        value = 1
    assert value == 1
    with pytest.raises(ValueError, match="inside"), interrupts.deferred():
        raise ValueError("inside")
    assert interrupts._deferring == []
    assert interrupts._pending == []
