"""SIGTERM stops ``train`` and ``simulate`` as Ctrl-C does: one line saying what was written,
no empty run folder left, and exit status 143 (128 + SIGTERM)."""

import signal
import subprocess
import sys
import time

import pytest

from warehouse_phys.apps import interrupts

#: Seconds a command may take to start and open its run folder on a busy machine.
START_LIMIT = 120


def terminate_once_running(command, cwd):
    """Start ``python -m <command>`` in ``cwd``, send it SIGTERM once its run folder is
    there, and return the finished process and its stderr."""
    process = subprocess.Popen(
        [sys.executable, "-m", *command], cwd=cwd, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    deadline = time.monotonic() + START_LIMIT
    try:
        while not [p for p in (cwd / "runs").glob("*") if p.is_dir()]:
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, "no run folder appeared"
            time.sleep(0.05)
        time.sleep(0.5)  # into the run itself
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    return process, err


@pytest.mark.parametrize(
    "command",
    [
        ["warehouse_phys.simulate", "--layout", "warehouse", "--robots", "64",
         "--steps", "10000000", "--no-compare", "--quiet"],
        ["warehouse_phys.train", "--env", "grid", "--episodes", "10000000", "--quiet"],
    ],
    ids=["simulate", "train"],
)  # fmt: skip
def test_sigterm_says_what_was_written_removes_the_empty_run_folder_and_exits_143(
    tmp_path, command
):
    process, err = terminate_once_running(command, tmp_path)
    assert process.returncode == 143, err
    prog = f"python -m {command[0]}"
    assert err == f"{prog}: terminated; nothing was written\n"
    assert list(tmp_path.iterdir()) == []  # the run folder is gone, and runs/ it made


def test_sigterm_after_some_files_names_them_and_leaves_no_half_written_file(
    tmp_path, capsys, monkeypatch
):
    from warehouse_phys.apps.simulate import main
    from warehouse_phys.drawing.animation import Animation

    def terminated(self, path):
        raise interrupts.Terminated  # as SIGTERM arriving while the GIF is written

    monkeypatch.setattr(Animation, "save", terminated)
    out = tmp_path / "run"
    argv = ["--robots", "2", "--steps", "5", "--frames", "2", "--no-compare", "--quiet",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 143
    assert capsys.readouterr().err == (
        "python -m warehouse_phys.simulate: terminated; summary.json, throughput.png, "
        f"congestion.png are complete in {out}\n"
    )
    assert sorted(p.name for p in out.iterdir()) == [
        "congestion.png", "summary.json", "throughput.png"
    ]  # fmt: skip


@pytest.mark.parametrize(
    "command",
    [
        ("warehouse_phys.apps.simulate", ["--robots", "2", "--steps", "5", "--no-compare",
                                          "--quiet"]),
        ("warehouse_phys.apps.train", ["--env", "grid", "--episodes", "5", "--quiet"]),
    ],
    ids=["simulate", "train"],
)  # fmt: skip
@pytest.mark.parametrize("moment", ["runs created", "created", "locked"])
def test_sigterm_while_the_run_folder_is_opened_leaves_no_folder(
    tmp_path, capsys, monkeypatch, command, moment
):
    """A first run creates runs/, then its folder in it, then opens and locks that: a
    SIGTERM right after any of these steps (here sent by the step itself) removes both."""
    import importlib

    module, argv = command
    main = importlib.import_module(module).main
    sent = _sigterm_after(monkeypatch, moment, "runs")
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 143
    prog = "python -m " + module.replace(".apps", "")
    assert capsys.readouterr().err == f"{prog}: terminated; nothing was written\n"
    assert sent == [moment]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("moment", ["sweeps created", "created", "locked"])
def test_sigterm_while_a_first_sweep_makes_its_folder_leaves_no_folder(
    tmp_path, capsys, monkeypatch, moment
):
    from warehouse_phys.apps import sweep

    monkeypatch.setattr(sweep, "run_on_tune", lambda *a, **k: pytest.fail("Ray was started"))
    sent = _sigterm_after(monkeypatch, moment, "sweeps")
    monkeypatch.chdir(tmp_path)
    assert sweep.main(["--seeds", "1", "--quiet"]) == 143
    assert sent == [moment]
    assert capsys.readouterr().err.startswith("python -m warehouse_phys.sweep: terminated;")
    assert list(tmp_path.iterdir()) == []


def test_a_refused_argument_or_an_early_interrupt_leaves_no_runs_folder(tmp_path, monkeypatch):
    """Before the run folder is made (arguments, floors, the planner's set-up) nothing
    is on disk, and nothing is left."""
    from warehouse_phys.apps import simulate, train

    monkeypatch.chdir(tmp_path)
    assert simulate.main(["--robots", "300", "--quiet"]) == 2
    assert train.main(["--episodes", "0"]) == 2

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # Ctrl-C while the fleet is being built

    monkeypatch.setattr(simulate, "parallel_env", interrupted)
    assert simulate.main(["--robots", "2", "--quiet"]) == 130
    assert list(tmp_path.iterdir()) == []


def _sigterm_after(monkeypatch, moment, parent):  # -> the moments it was sent at
    """Send SIGTERM right after ``moment``: the first run's ``parent`` folder (runs/,
    sweeps/) is created, its own folder is created, or its folder is locked."""
    from warehouse_phys.files import runfolder

    step = (runfolder.fcntl, "flock") if moment == "locked" else (runfolder.Path, "mkdir")
    real = getattr(*step)
    sent = []

    def then_sigterm(*args, **kwargs):
        result = real(*args, **kwargs)
        made_parent = step[1] == "mkdir" and args[0].name == parent
        if not sent and (moment == f"{parent} created") == made_parent:
            sent.append(moment)
            signal.raise_signal(signal.SIGTERM)
        return result

    monkeypatch.setattr(*step, then_sigterm)
    return sent
