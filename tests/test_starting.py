"""Ctrl-C while a command is still importing: one line, no traceback, exit status 130 (or
death by SIGINT, which a shell reports as 130); a program importing the package gets its
KeyboardInterrupt back."""

import os
import signal
import subprocess
import sys
import time

import pytest

from tests.conftest import ROOT
from warehouse_phys._starting import (
    command_interrupts,
    pass_on_ignored_interrupts,
    started_command,
)

#: After Python's own start (about 0.1 s, beyond the package's reach), within the imports.
DELAYS = [0.3, 0.5]


@pytest.mark.parametrize("delay", DELAYS)
@pytest.mark.parametrize("module", ["warehouse_phys.simulate", "warehouse_phys.train"])
def test_ctrl_c_while_a_command_imports_prints_one_line(module, delay):
    process = subprocess.Popen(
        [sys.executable, "-m", module, "--robots", "0"], cwd=ROOT, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert "Traceback" not in err, err
    prog = f"python -m {module}"
    refused = f"{prog}: error: argument --robots"
    if process.returncode == 2 or refused in err:  # the imports were over: it had refused
        # the argument (the interrupt may land while it exits, after its one line)
        pytest.skip("the command had started before the interrupt")
    assert process.returncode in (130, -signal.SIGINT), err
    assert err.strip().splitlines()[-1] in (
        f"{prog}: interrupted while starting; nothing was written",
        f"{prog}: interrupted; nothing was written",
    )


#: Loaded by the command's Python (sitecustomize): Ctrl-C sent to itself as the command
#: imports ``TARGET``, found by this finder on the import system's path of lookups.
INTERRUPT_AT_IMPORT = """
import os
import signal
import sys


class InterruptAt:
    def find_spec(self, name, path=None, target=None):
        if name == {target!r}:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None


sys.meta_path.insert(0, InterruptAt())
"""


@pytest.mark.parametrize(
    ("module", "target"),
    [
        ("warehouse_phys.train", "warehouse_phys.envs.base"),  # the package's own imports
        ("warehouse_phys.train", "warehouse_phys.apps.train"),  # the command's
        # Within numba's compiled _dispatcher, whose start prints an interrupt's traceback
        # itself and fails with ImportError: the interrupt must not land there.
        ("warehouse_phys.simulate", "numba._devicearray"),
        # By the long names, the app's own imports come after the package's block.
        ("warehouse_phys.apps.simulate", "numba._devicearray"),  # the app package's
        ("warehouse_phys.apps.sweep", "warehouse_phys.apps.sweep.trials"),
        ("warehouse_phys.apps.train", "warehouse_phys.apps.train_eval"),  # the app module's
        ("warehouse_phys.apps.play", "warehouse_phys.planners.pibt"),
        ("warehouse_phys.apps.startkit", "warehouse_phys.lorr.startkit.install"),
    ],
)
def test_ctrl_c_at_any_import_of_a_command_prints_one_line(tmp_path, module, target):
    (tmp_path / "sitecustomize.py").write_text(INTERRUPT_AT_IMPORT.format(target=target))
    result = subprocess.run(
        [sys.executable, "-m", module, "--robots", "0"], cwd=ROOT, capture_output=True,
        text=True, timeout=60, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])},
    )  # fmt: skip
    command = "python -m " + module.replace(".apps.", ".")  # the command's own name
    assert result.stderr == f"{command}: interrupted while starting; nothing was written\n"
    assert result.returncode == 130


def test_a_program_that_imports_the_package_gets_its_interrupt_back(monkeypatch):
    monkeypatch.setattr(sys, "orig_argv", ["python", "-m", "warehouse_phys.simulate"])
    monkeypatch.setattr(sys, "argv", ["-m"])  # as while -m locates its module
    with pytest.raises(SystemExit) as stopped, command_interrupts():
        raise KeyboardInterrupt
    assert stopped.value.code == 130
    monkeypatch.setattr(sys, "argv", ["script.py"])  # a script imports the package
    with pytest.raises(KeyboardInterrupt), command_interrupts():
        raise KeyboardInterrupt
    monkeypatch.setattr(sys, "orig_argv", ["python", "-m", "pytest"])
    assert started_command() is None
    with pytest.raises(KeyboardInterrupt), command_interrupts(True):
        raise KeyboardInterrupt
    monkeypatch.setattr(sys, "orig_argv", ["python", "-m", "warehouse_phys.apps.simulate"])
    assert started_command() == "python -m warehouse_phys.simulate"


def test_an_interrupt_python_ignores_in_its_own_callback_still_ends_the_command(
    monkeypatch, capsys
):
    # Python ignores an exception raised in a callback it runs (a finaliser here; the
    # import system's module-lock callbacks in a command's start), printing "Exception
    # ignored" and a traceback. A command passes the interrupt on to its main thread.
    monkeypatch.setattr(sys, "orig_argv", ["python", "-m", "warehouse_phys.simulate"])
    others = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: others.append(unraisable))
    pass_on_ignored_interrupts()
    pass_on_ignored_interrupts()  # once: not a hook round a hook
    # Python's own Ctrl-C handler, as a command started from a terminal has it.
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)

    class Interrupted:
        def __del__(self):
            raise KeyboardInterrupt

    def start():
        with command_interrupts(running=True):
            Interrupted()  # gone at once: its interrupt goes to sys.unraisablehook
            for _ in range(10_000):  # the interrupt lands within a few switches
                time.sleep(0)

    try:
        with pytest.raises(SystemExit) as stopped:
            start()
    finally:
        signal.signal(signal.SIGINT, handler)
    assert stopped.value.code == 130
    err = capsys.readouterr().err
    assert "Exception ignored" not in err, err
    assert err == (
        "python -m warehouse_phys.simulate: interrupted while starting; nothing was written\n"
    )
    assert others == []
    # Any other exception Python ignores still goes to the hook there was.

    class Broken:
        def __del__(self):
            raise ZeroDivisionError

    Broken()
    assert [type(unraisable.exc_value) for unraisable in others] == [ZeroDivisionError]
