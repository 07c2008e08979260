"""A run killed half way goes on from its last checkpoint, in another process, and plays
exactly the steps of the run that was never stopped; a checkpoint of another job, of
another version of the package, or one that does not read, is not used; a checkpoint
that cannot be written does not stop the run."""

import json
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tests.apps.test_evaluate import killed_after, tiny_instance
from tests.conftest import ROOT
from warehouse_phys.apps.evaluate import checkpoints, suite
from warehouse_phys.apps.evaluate.checkpoints import (
    CHECKPOINT_SUFFIX,
    checkpoint_path,
    load_checkpoint,
)
from warehouse_phys.apps.evaluate.suite import RUNS_DIR, Job, run_job

#: The step after which the first process dies, and the run's length [steps].
KILLED_AT, STEPS = 23, 50

#: Plays each job of ``sys.argv[1]`` (JSON) into the folder ``sys.argv[2]``, saving its
#: state after every step, and stops it (an exception, as a kill would) once the state
#: after step ``KILLED_AT`` is saved.
KILLER = """
import json, sys
from warehouse_phys.apps.evaluate import suite

class Killed(Exception):
    pass

save = suite.save_checkpoint

def save_then_die(path, job, state):
    save(path, job, state)
    if len(state.progress.done) == {killed}:
        raise Killed

suite.save_checkpoint = save_then_die
for job in json.loads(sys.argv[1]):
    try:
        suite.run_job(job, sys.argv[2], checkpoint_seconds=0.0)
    except Killed:
        continue
    raise SystemExit("the run was not stopped")
"""


def jobs(folder):
    instance = str(tiny_instance(folder, robots=6))
    threads = {"first_search_batch": 4, "workers": 2}  # the guide searches' threads too
    return [
        Job("pibt", instance, 0, STEPS, scheduler="rematch-backlog"),
        Job("guided-ops-repair", instance, 1, STEPS, scheduler="rematch-backlog", guidance=threads),
    ]


def played(job, folder, monkeypatch):
    """Play ``job`` saving its state at every step; its row, and what each step finished
    and where the robots stood and faced at the end, as its last save held them."""
    save, last = suite.save_checkpoint, {}

    def save_and_keep(path, described, state):
        save(path, described, state)
        env = state.env
        last.update(done=list(state.progress.done), cells=np.copy(env.robot_cells),
                    headings=np.copy(env.robot_headings))  # fmt: skip

    with monkeypatch.context() as patched:
        patched.setattr(suite, "save_checkpoint", save_and_keep)
        row = run_job(job.to_dict(), str(folder), checkpoint_seconds=0.0)
    return row, last


def test_a_run_killed_half_way_goes_on_in_another_process_as_if_never_stopped(
    tmp_path, monkeypatch
):
    planned = jobs(tmp_path)
    script = textwrap.dedent(KILLER).format(killed=KILLED_AT)
    killed = subprocess.run(
        [sys.executable, "-c", script, json.dumps([job.to_dict() for job in planned]),
         str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert killed.returncode == 0, killed.stderr
    (tmp_path / "unbroken").mkdir()
    for job in planned:
        saved = checkpoint_path(tmp_path, RUNS_DIR, job.name)
        # The fleet's distance maps keep the rows in use, not the 900 MiB reserved for them.
        assert saved.stat().st_size < 2**22
        assert len(load_checkpoint(saved, job.to_dict()).progress.done) == KILLED_AT
        resumed, resumed_end = played(job, tmp_path, monkeypatch)
        unbroken, unbroken_end = played(job, tmp_path / "unbroken", monkeypatch)
        assert resumed["resumed_at"] == [KILLED_AT]
        assert unbroken["resumed"] == 0
        assert resumed_end["done"] == unbroken_end["done"]  # step by step, to step 49
        assert resumed_end["done"][-1] > 0
        assert np.array_equal(resumed_end["cells"], unbroken_end["cells"])
        assert np.array_equal(resumed_end["headings"], unbroken_end["headings"])
        assert resumed["finished"] == unbroken["finished"]
        assert resumed["refused"] == unbroken["refused"] == 0
        assert not saved.exists()  # a finished run removes its checkpoint


@pytest.fixture
def saved(tmp_path, monkeypatch):
    """A job of 6 steps, and its checkpoint after 5."""
    job = Job(**{**jobs(tmp_path)[0].to_dict(), "steps": 6})
    return job.to_dict(), killed_after(5, job, tmp_path, monkeypatch)


def test_a_checkpoint_of_another_job_version_or_form_is_not_used(saved, monkeypatch):
    job, path = saved
    assert len(load_checkpoint(path, job).progress.done) == 5
    assert load_checkpoint(path, {**job, "steps": 7}) is None  # another job
    assert load_checkpoint(path.with_name("none" + CHECKPOINT_SUFFIX), job) is None
    with monkeypatch.context() as patched:
        patched.setattr(checkpoints, "source_digest", lambda: "another version")
        assert load_checkpoint(path, job) is None
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])  # cut short
    assert load_checkpoint(path, job) is None
    path.write_bytes(pickle.dumps({"format": 1}))
    assert load_checkpoint(path, job) is None


def test_a_changed_instance_file_is_another_instance(saved):
    job, path = saved
    instance = Path(job["instance"])
    instance.write_text(instance.read_text() + "\n")
    assert load_checkpoint(path, job) is None


def test_a_run_with_a_checkpoint_it_cannot_use_starts_afresh(saved):
    job, path = saved
    path.write_bytes(b"not a pickle")
    row = run_job(job, str(path.parent.parent), checkpoint_seconds=3600.0)
    assert row["resumed"] == 0
    assert row["finished"] == run_job(job)["finished"]


def test_a_run_that_saves_none_still_goes_on_from_a_checkpoint(saved, monkeypatch):
    job, path = saved
    monkeypatch.setattr(suite, "save_checkpoint", lambda *args: pytest.fail("saved"))
    row = run_job(job, str(path.parent.parent), checkpoint_seconds=None)
    assert row["resumed_at"] == [5]
    assert not path.exists()


def test_a_checkpoint_that_cannot_be_written_does_not_stop_the_run(tmp_path, monkeypatch):
    job = jobs(tmp_path)[0].to_dict()

    def full(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(suite, "save_checkpoint", full)
    row = run_job(job, str(tmp_path), checkpoint_seconds=0.0)
    assert row["steps"] == STEPS
    assert row["checkpoint_error"] == "OSError: [Errno 28] No space left on device"
    assert run_job(job)["checkpoint_error"] is None
