"""A run killed half way goes on from its last checkpoint, in another process, and ends
exactly as the run that was never stopped; a checkpoint of another job, of another version
of the package, or one that does not read, is not used."""

import pickle
import subprocess
import sys
import textwrap

import pytest

from tests.apps.test_evaluate import tiny_instance
from tests.conftest import ROOT
from warehouse_phys.apps.evaluate import checkpoints
from warehouse_phys.apps.evaluate.checkpoints import (
    CHECKPOINT_SUFFIX,
    checkpoint_path,
    load_checkpoint,
)
from warehouse_phys.apps.evaluate.suite import RUNS_DIR, Job, run_job

#: The step after which the first process dies, and the run's length [steps].
KILLED_AT, STEPS = 23, 50
#: What the run counts, besides its times.
COUNTED = ("finished", "per_step", "first_third", "middle_third", "last_third", "refused")

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


def test_a_run_killed_half_way_goes_on_in_another_process_as_if_never_stopped(tmp_path):
    import json

    planned = jobs(tmp_path)
    script = textwrap.dedent(KILLER).format(killed=KILLED_AT)
    killed = subprocess.run(
        [sys.executable, "-c", script, json.dumps([job.to_dict() for job in planned]),
         str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert killed.returncode == 0, killed.stderr
    for job in planned:
        saved = checkpoint_path(tmp_path, RUNS_DIR, job.name)
        # The fleet's distance maps keep the rows in use, not the 900 MiB reserved for them.
        assert saved.stat().st_size < 2**22
        state = load_checkpoint(saved, job.to_dict())
        assert len(state.progress.done) == KILLED_AT
        resumed = run_job(job.to_dict(), str(tmp_path), checkpoint_seconds=0.0)
        unbroken = run_job(job.to_dict())
        assert resumed["resumed_at"] == [KILLED_AT]
        assert unbroken["resumed"] == 0
        assert [resumed[key] for key in COUNTED] == [unbroken[key] for key in COUNTED]
        assert resumed["finished"] > 0
        # The last state saved is the one before the last step; the suite removes it.
        assert len(load_checkpoint(saved, job.to_dict()).progress.done) == STEPS - 1


@pytest.fixture
def saved(tmp_path):
    """A job, and its checkpoint after 5 steps."""
    job = jobs(tmp_path)[0].to_dict()
    run_job({**job, "steps": 6}, str(tmp_path), checkpoint_seconds=0.0)  # another job's name
    path = checkpoint_path(tmp_path, RUNS_DIR, Job(**{**job, "steps": 6}).name)
    return job, path


def test_a_checkpoint_of_another_job_version_or_form_is_not_used(saved, monkeypatch):
    job, path = saved
    six = {**job, "steps": 6}
    assert len(load_checkpoint(path, six).progress.done) == 5
    assert load_checkpoint(path, job) is None  # another job: 50 steps
    assert load_checkpoint(path.with_name("none" + CHECKPOINT_SUFFIX), six) is None
    monkeypatch.setattr(checkpoints, "source_digest", lambda: "another version")
    assert load_checkpoint(path, six) is None
    monkeypatch.undo()
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])  # cut short
    assert load_checkpoint(path, six) is None
    path.write_bytes(pickle.dumps({"format": 1}))
    assert load_checkpoint(path, six) is None


def test_a_run_with_a_checkpoint_it_cannot_use_starts_afresh(saved):
    job, path = saved
    six = {**job, "steps": 6}
    path.write_bytes(b"not a pickle")
    row = run_job(six, str(path.parent.parent), checkpoint_seconds=3600.0)
    assert row["resumed"] == 0
    assert row["steps"] == 6
    assert [row[key] for key in COUNTED] == [run_job(six)[key] for key in COUNTED]
