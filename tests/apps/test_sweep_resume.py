"""Resuming a sweep: finished trials, the folder check, the locks of the driver and of
the trials, lingering workers of a killed driver."""

import io
import os
import shutil
import subprocess
import sys
import time
from contextlib import redirect_stderr, redirect_stdout

import pytest

from tests.apps.test_sweep import read_rows, run_sweep
from warehouse_phys import sweep as sweep_cli
from warehouse_phys.apps.sweep import on_ray as sweep_ray
from warehouse_phys.apps.sweep import resume as sweep_resume
from warehouse_phys.apps.sweep import trials as sweep_trials
from warehouse_phys.files.runfolder import RunFolderError
from warehouse_phys.rl.qlearning import load_q_table


def test_a_folder_of_other_files_is_refused(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep")
    (out / "runs").mkdir()
    assert sweep_cli.main(["--seeds", "1", "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"python -m warehouse_phys.sweep: error: --out {out} holds files that are not a "
        "sweep's (notes.txt); choose a new or empty folder, or an earlier sweep's folder to "
        "resume it\n"
    )
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "runs"]
    (out / "notes.txt").unlink()
    (out / ".results.csv.x1y2.tmp").write_text("")  # a killed sweep's half-written table
    sweep_resume.check_sweep_folder(out)  # an earlier sweep's folder: resumed


# ---------------------------------------------------------------------- issue 32: resume, lingering
def tune_in_process(jobs, sweep_dir, **options):
    """``run_on_tune`` without Ray: every job in this process, its error kept as Tune keeps it."""
    outcomes = {}
    for job in jobs:
        try:
            outcomes[job["name"]] = sweep_ray.run_trial(job)
        except Exception as error:
            outcomes[job["name"]] = error
    return outcomes


@pytest.fixture(scope="module")
def finished_template(tmp_path_factory):
    """A two-trial sweep run once for the module, in this process: its folder and argv.
    Each test works on a copy (:func:`finished_sweep`), so none sees another's changes;
    a sweep of its own each (its runs' figures most of the cost) bought nothing more."""
    out = tmp_path_factory.mktemp("finished") / "sweep"
    argv = ["--seeds", "2", "--episodes", "60", "--out", str(out)]
    printed, errors = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as patched, redirect_stdout(printed), redirect_stderr(errors):
        patched.setattr(sweep_cli, "run_on_tune", tune_in_process)
        status = sweep_cli.main(argv)
    assert status == 0, errors.getvalue()
    assert "2 trials in" in printed.getvalue()
    return out, argv


@pytest.fixture
def finished_sweep(tmp_path, finished_template):
    """A finished two-trial sweep of this test's own (a copy, files and times as the sweep
    left them, its lock file and token included): its folder, argv and trials."""
    template, argv = finished_template
    out = tmp_path / "sweep"
    shutil.copytree(template, out)
    argv = [*argv[:-1], str(out)]
    trials = sweep_trials.trials_from_args(sweep_cli.build_parser().parse_args(argv))
    return out, argv, trials


def test_a_truncated_or_foreign_table_is_trained_again_on_resume(
    finished_sweep, monkeypatch, capsys
):
    out, argv, trials = finished_sweep
    monkeypatch.setattr(sweep_cli, "run_on_tune", tune_in_process)
    assert all(sweep_resume.finished_row(trial, out) for trial in trials)
    table = out / trials[1].folder / "qtable.npz"
    data = table.read_bytes()
    table.write_bytes(data[: len(data) // 2])  # the summary still says done
    assert sweep_resume.finished_row(trials[1], out) is None
    assert sweep_resume.finished_row(trials[0], out)["status"] == "done"

    assert sweep_cli.main(argv) == 0
    assert f"2 trials in {out}: 1 already finished, 1 to run" in capsys.readouterr().out
    _, metadata = load_q_table(table)
    assert metadata["seed"] == 1
    # Seed 0's table in seed 1's folder: it loads, but is not this trial's run.
    table.write_bytes((out / trials[0].folder / "qtable.npz").read_bytes())
    assert sweep_resume.finished_row(trials[1], out) is None


def test_a_sweep_folder_in_use_by_a_live_sweep_is_refused_naming_its_pid(tmp_path, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    handle, token = sweep_resume.take_sweep_lock(out)  # a live driver: this process
    try:
        assert token.split()[0] == str(os.getpid())
        assert sweep_cli.main(["--seeds", "1", "--out", str(out)]) == 2
        assert capsys.readouterr().err == (
            f"python -m warehouse_phys.sweep: error: --out {out} is in use by the sweep of "
            f"process {os.getpid()}; wait for it to end or choose another folder\n"
        )
        assert sorted(p.name for p in out.iterdir()) == ["sweep.lock"]
    finally:
        os.close(handle)


def test_a_killed_drivers_lock_is_taken_over_with_a_new_token(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    (out / "sweep.lock").write_text("4194304 0123456789abcdef\n")  # no process holds it
    monkeypatch.setattr(sweep_cli, "run_on_tune", tune_in_process)
    assert sweep_cli.main(["--seeds", "1", "--episodes", "30", "--out", str(out)]) == 0
    pid, token = (out / "sweep.lock").read_text().split()
    assert pid == str(os.getpid())
    assert len(token) == 32
    sweep_resume.check_sweep_folder(out)  # the lock is one of the sweep's own files


def test_a_lingering_worker_of_an_earlier_run_touches_nothing(finished_sweep):
    out, _, trials = finished_sweep
    folder = out / trials[0].folder
    before = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    old_job = trials[0].to_job(out, gif=False, run="1 earlier-run")  # not the lock's token
    with pytest.raises(sweep_resume.SupersededError, match=r"a newer run .* owns the folder"):
        sweep_ray.run_trial(old_job)
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == before
    # A trial of the current run, the token in the lock file, trains as ever.
    current = (out / "sweep.lock").read_text().strip()
    assert sweep_ray.run_trial(trials[0].to_job(out, gif=False, run=current))["optimal"] >= 0


def hold_folder(folder):
    """Lock ``folder`` as a run writing it does; returns the handle that releases it."""
    import fcntl

    handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    return handle


def held(folder):
    """Whether a process holds ``folder``'s lock (a run writing it)."""
    import fcntl

    handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(handle)
    return False


def test_a_folder_held_by_a_lingering_worker_is_not_finished_and_is_waited_for(
    finished_sweep, monkeypatch
):
    import threading

    out, _, trials = finished_sweep
    folder = out / trials[0].folder
    handle = hold_folder(folder)
    try:
        assert sweep_resume.finished_row(trials[0], out) is None  # it may be half-written
        monkeypatch.setattr(sweep_resume, "FOLDER_WAIT", 0.2)
        with pytest.raises(RunFolderError, match="in use by another run"):
            sweep_ray.run_trial(trials[0].to_job(out, gif=False))
        monkeypatch.setattr(sweep_resume, "FOLDER_WAIT", 60.0)
        results = []
        worker = threading.Thread(
            target=lambda: results.append(sweep_ray.run_trial(trials[0].to_job(out, gif=False)))
        )
        worker.start()
        time.sleep(1.0)
        assert worker.is_alive()  # waiting for the folder
        assert not results
    finally:
        os.close(handle)
    worker.join(60)
    assert [r["training_episodes"] for r in results] == [60]
    assert sweep_resume.finished_row(trials[0], out)["status"] == "done"


def patched_on_import(module: str, patch: str) -> str:
    """A ``sitecustomize`` for the sweep's Python processes, its Ray workers included:
    when ``module`` of the package is imported, it runs and then ``patch(module)`` (the
    source ``patch`` defines) changes it."""
    return f"""
import importlib.util
import os
import pathlib
import subprocess
import sys
import time

{patch}

class PatchOnImport:
    def find_spec(self, name, path=None, target=None):
        if name != {module!r}:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        run_module = spec.loader.exec_module

        def exec_module(module):
            run_module(module)
            patch(module)

        spec.loader.exec_module = exec_module
        return spec


sys.meta_path.insert(0, PatchOnImport())
"""


#: The killed sweep's trial stalls with its folder locked, and a process of its own keeps
#: the folder's lock (a worker that Ray is slow to end, as under load) until the new run's
#: worker has found the folder held (the mark at $WAITED_MARK), or for two minutes at
#: most. The stalled worker lets go of its own copy of the lock, and would remove nothing
#: if it ended, so that whenever and however Ray ends it, the folder stays that process's.
STALL_TRIALS = patched_on_import("warehouse_phys.apps.runs", """
LINGER = 'for i in $(seq 1200); do [ -e "$0" ] && break; sleep 0.1; done &'


def patch(module):
    def train_run(folder, *args, **kwargs):
        # Detached ("&") in a session of its own: Ray ends a worker's children and its
        # process group with it, not this process.
        subprocess.Popen(["sh", "-c", LINGER, os.environ["WAITED_MARK"]],
                         pass_fds=[folder._handle], start_new_session=True)
        os.close(folder._handle)
        folder._handle, folder._created = None, []  # however it ends: nothing removed
        time.sleep(600)

    module.train_run = train_run
""")  # fmt: skip

#: The new run's trial that finds its folder held by another process, and so waits for
#: it, leaves the mark at $WAITED_MARK.
MARK_WAITING = patched_on_import("warehouse_phys.apps.sweep.resume", """
def patch(module):
    held_by_another = module._held_by_another

    def held(folder):
        if held_by_another(folder):
            pathlib.Path(os.environ["WAITED_MARK"]).touch()
            return True
        return False

    module._held_by_another = held
""")  # fmt: skip


def hook_env(folder, hook, mark):
    """The environment of a sweep whose Python processes load ``hook`` (a sitecustomize)."""
    folder.mkdir()
    (folder / "sitecustomize.py").write_text(hook)
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(folder), *sys.path]),
            "WAITED_MARK": str(mark)}  # fmt: skip


@pytest.mark.slow
def test_a_sweep_run_again_at_once_after_its_driver_is_killed_succeeds(tmp_path):
    # A worker of the killed driver lingers, the trial's folder locked, while the new run
    # starts: the new run's worker waits for the folder (it failed "in use" before).
    mark = tmp_path / "waited"
    out = tmp_path / "sweep"
    argv = ["--seeds", "1", "--episodes", "60", "--out", str(out), "--quiet"]
    folder = out / "runs/grid-default-a0.9-g0.9-e60-seed0"
    driver = subprocess.Popen(
        [sys.executable, "-m", "warehouse_phys.apps.sweep", *argv], cwd=tmp_path,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        env=hook_env(tmp_path / "stall", STALL_TRIALS, mark),
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not (folder.is_dir() and held(folder)):
            assert driver.poll() is None, "the sweep ended before its trial started"
            assert time.monotonic() < deadline, "the trial never started"
            time.sleep(0.1)
    finally:
        driver.kill()  # SIGKILL: Ray is not shut down
        driver.wait()
    try:
        assert held(folder)  # by the lingering process
        again = run_sweep(*argv, cwd=tmp_path, env=hook_env(tmp_path / "mark", MARK_WAITING, mark))
        assert again.returncode == 0, again.stderr
        assert mark.exists(), "the new run's trial never found the folder held"
    finally:
        mark.touch()  # the lingering process lets go, whatever failed
    assert [row["status"] for row in read_rows(out)] == ["done"]
    _, metadata = load_q_table(folder / "qtable.npz")
    assert metadata["episodes"] == 60
    assert (out / "sweep.lock").read_text().split()[0] != str(driver.pid)
