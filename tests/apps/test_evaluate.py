"""``python -m warehouse_phys.evaluate``: one row per run, counted as the competition counts,
a suite that resumes where it stopped, the archive's best-known table read, and refused
arguments in one line."""

import json
import time

import numpy as np
import pytest

from warehouse_phys import evaluate as evaluate_cli
from warehouse_phys.apps.evaluate import suite
from warehouse_phys.apps.evaluate.best_known import (
    best_known_for,
    main_round_instances,
    read_best_known,
)
from warehouse_phys.apps.evaluate.checkpoints import checkpoint_path
from warehouse_phys.apps.evaluate.report import RESULTS_CSV, RESULTS_MD, RESULTS_PNG, write_results
from warehouse_phys.apps.evaluate.suite import RUNS_DIR, Job, finished_rows, run_job, write_row
from warehouse_phys.apps.interrupts import Terminated
from warehouse_phys.lorr.instances import LorrInstance, write_instance
from warehouse_phys.world.grid import WarehouseGrid

PROG = "python -m warehouse_phys.evaluate"


def tiny_instance(folder, name="tiny", robots=3):
    """A 2024 instance on a small floor: two-stop tasks, 1.5 x N revealed."""
    floor = WarehouseGrid.from_layout(["........", ".##.##..", "........"])
    rng = np.random.default_rng(0)
    free = np.flatnonzero(np.asarray(floor.free_mask).reshape(-1))
    tasks = rng.choice(free, (40, 2))
    problem = LorrInstance(name=name, grid=floor, starts=list(range(robots)),
                           task_offsets=np.arange(41) * 2, task_stops=tasks.ravel(),
                           num_tasks_reveal=1.5, assignment="scheduler",
                           version="2024 LoRR")  # fmt: skip
    return write_instance(problem, folder / name / f"{name}.json")


def fake_archive(folder, instance):
    """A Benchmark-Archive with one 2024 main-round instance and its best known."""
    main = folder / "2024 Competition" / "Main Round Evaluation Instances"
    (main / "warehouse.domain").mkdir(parents=True)
    for path in instance.parent.rglob("*"):
        if path.is_file():
            target = main / "warehouse.domain" / path.relative_to(instance.parent)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(path.read_bytes())
    (main / "simulation_time.json").write_text(json.dumps({"tiny": 30}))
    (folder / "2024 Competition" / "README.md").write_text(
        "| Instance | Total Tasks Finished | Domain | # Agents | Simulation Time  | Team |\n"
        "| --- | --- | --- | --- | --- | --- |\n"
        "| MR24-tiny | 12 | Warehouse | 3 | 30 | someone |\n"
    )
    return folder


def test_a_run_counts_tasks_and_sets_them_beside_the_best_known(tmp_path):
    path = tiny_instance(tmp_path)
    job = Job("guided", str(path), 0, 30, best=(12, 30))
    row = run_job(job.to_dict())
    assert row["steps"] == 30
    assert row["refused"] == 0
    assert row["per_step"] == pytest.approx(row["finished"] / 30)
    assert row["fraction_of_best"] == pytest.approx(row["per_step"] / 0.4)
    thirds = [row["first_third"], row["middle_third"], row["last_third"]]
    assert sum(thirds) * 10 == pytest.approx(row["finished"])
    assert row["first_step_cpu_s"] >= 0
    assert row["peak_mib"] > 0
    assert run_job(job.to_dict())["finished"] == row["finished"]  # the same for a seed


def test_a_run_with_the_assignment_scheduler_and_the_repair(tmp_path):
    path = tiny_instance(tmp_path, robots=4)
    job = Job("guided-repair", str(path), 0, 30, scheduler="assignment=0.5")
    row = run_job(job.to_dict())
    assert row["refused"] == 0
    assert row["finished"] > 0
    assert run_job(job.to_dict())["finished"] == row["finished"]
    assert job.name != Job("guided-repair", str(path), 0, 30, scheduler="makespan").name


def test_finished_rows_are_kept_and_a_broken_file_is_not_finished(tmp_path):
    jobs = [Job("guided", "a.json", 0, 10), Job("guided", "a.json", 1, 10)]
    write_row(tmp_path, {"name": jobs[0].name, "steps": 10, "per_step": 1.0})
    (tmp_path / "runs" / f"{jobs[1].name}.json").write_text('{"name": ')  # killed mid-write
    assert list(finished_rows(tmp_path, jobs)) == [jobs[0].name]
    assert jobs[0].name != Job("guided", "a.json", 0, 10, guidance={"refresh": 1}).name


def test_the_archive_table_and_its_main_round(tmp_path):
    archive = fake_archive(tmp_path / "archive", tiny_instance(tmp_path))
    table = read_best_known(archive)
    assert best_known_for("tiny", table).per_step == pytest.approx(0.4)
    assert best_known_for("other", table) is None
    ((path, steps),) = main_round_instances(archive, 2024)
    assert (path.name, steps) == ("tiny.json", 30)
    with pytest.raises(ValueError, match="no 2023 main round"):
        main_round_instances(archive, 2023)
    with pytest.raises(ValueError, match="no best-known table"):
        read_best_known(tmp_path)


def test_the_table_and_figure_are_written(tmp_path):
    rows = [{"instance": "a", "planner": "guided", "seed": 0, "per_step": 2.0,
             "fraction_of_best": 0.8}, {"instance": "b", "planner": "guided", "seed": 0,
             "per_step": 3.0, "fraction_of_best": None},
            {"instance": "c", "error": "boom"}]  # fmt: skip
    write_results(tmp_path, rows)
    assert (tmp_path / RESULTS_CSV).read_text().count("\n") == 4
    assert "| a | guided | 0 |" in (tmp_path / RESULTS_MD).read_text()
    assert (tmp_path / RESULTS_PNG).stat().st_size > 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["--planners", "fast"], "unknown planner 'fast'"),
     (["--guidance", '{"vertex_weight": -1}'], "vertex_weight"),
     (["--scheduler", "fastest"], "unknown scheduler 'fastest'"),
     (["--scheduler", "assignment=-1"], "a weight W from 0 to 1000"),
     (["--seeds", "a"], "--seeds"),
     (["--rounds", "2024"], "--rounds needs --archive"),
     (["--instances", "missing.json"], "--instances")],
)  # fmt: skip
def test_refused_arguments_are_one_line_and_exit_2(tmp_path, capsys, argv, message):
    if "--instances" not in argv and "--rounds" not in argv:
        argv = [*argv, "--instances", str(tiny_instance(tmp_path))]
    assert evaluate_cli.main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{PROG}: error: ")
    assert message in err
    assert err.count("\n") == 1


def test_without_ray_the_suite_exits_2_with_the_install_line_and_writes_nothing(
    tmp_path, monkeypatch, capsys
):
    import importlib.util

    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name.split(".")[0] == "ray" else real_find_spec(name, *a),
    )
    out = tmp_path / "out"
    argv = ["--instances", str(tiny_instance(tmp_path)), "--out", str(out)]
    assert evaluate_cli.main(argv) == 2
    assert capsys.readouterr().err == (
        f"{PROG}: error: each run is a task on Ray, which is not installed: "
        'pip install "warehouse_phys[ray]"\n'
    )
    assert not out.exists()


def killed_after(step, job, folder, monkeypatch):
    """Play ``job`` into the suite's ``folder``, saving its state at every step, until the
    state after ``step`` is saved; the checkpoint's path."""
    save = suite.save_checkpoint

    def save_then_stop(path, described, state):
        save(path, described, state)
        if len(state.progress.done) == step:
            raise KeyboardInterrupt

    folder.mkdir(parents=True, exist_ok=True)
    with monkeypatch.context() as patched:
        patched.setattr(suite, "save_checkpoint", save_then_stop)
        with pytest.raises(KeyboardInterrupt):
            run_job(job.to_dict(), str(folder), checkpoint_seconds=0.0)
    return checkpoint_path(folder, RUNS_DIR, job.name)


def test_a_suite_on_ray_writes_its_table_and_resumes(tmp_path, capsys, monkeypatch):
    archive = fake_archive(tmp_path / "archive", tiny_instance(tmp_path))
    out = tmp_path / "suite"
    argv = ["--archive", str(archive), "--rounds", "2024", "--planners", "guided,pibt",
            "--steps", "12", "--out", str(out)]  # fmt: skip
    # A suite killed half way: the pibt run's state after 5 steps is in its folder.
    jobs = evaluate_cli.jobs_from_args(evaluate_cli.build_parser().parse_args(argv))
    pibt = next(job for job in jobs if job.planner == "pibt")
    checkpoint = killed_after(5, pibt, out, monkeypatch)
    started = time.monotonic()
    assert evaluate_cli.main(argv) == 0
    assert time.monotonic() - started < 180
    first = capsys.readouterr().out
    assert "2 runs" in first
    assert "0 already finished, 2 to run" in first
    table = (out / RESULTS_MD).read_text()
    assert table.count("| tiny |") == 2
    assert len(list((out / "runs").glob("*.json"))) == 2
    rows = {row["planner"]: row for row in finished_rows(out, jobs).values()}
    assert rows["pibt"]["resumed_at"] == [5]  # the Ray worker went on from the checkpoint
    assert rows["guided"]["resumed"] == 0
    assert rows["pibt"]["finished"] == run_job(pibt.to_dict())["finished"]
    assert not checkpoint.exists()  # removed once the row was written
    checkpoint.write_bytes(b"left by a suite stopped just after the row")
    cut_short = checkpoint.with_name(f".{checkpoint.name}.x1y2.tmp")  # a kill mid-write
    cut_short.write_bytes(b"half a checkpoint")
    assert evaluate_cli.main(argv) == 0  # resumes: nothing left to run
    assert "2 already finished, 0 to run" in capsys.readouterr().out
    assert not checkpoint.exists()
    assert not cut_short.exists()


@pytest.mark.parametrize(("stop", "status", "word"), [
    (KeyboardInterrupt, 130, "interrupted"), (Terminated, 143, "terminated"),
])  # fmt: skip
def test_a_stopped_suite_says_how_to_resume_and_keeps_what_it_saved(
    tmp_path, capsys, monkeypatch, stop, status, word
):
    out = tmp_path / "suite"
    argv = ["--instances", str(tiny_instance(tmp_path)), "--planners", "pibt", "--steps", "9",
            "--out", str(out)]  # fmt: skip
    [job] = evaluate_cli.jobs_from_args(evaluate_cli.build_parser().parse_args(argv))
    checkpoint = killed_after(4, job, out, monkeypatch)  # a run cut short, saved at step 4

    def stopped(*args):
        raise stop

    monkeypatch.setattr(evaluate_cli, "_run_on_ray", stopped)
    assert evaluate_cli.main(argv) == status
    assert capsys.readouterr().err.strip() == (
        f"{PROG}: {word}; finished runs are kept and the others as last saved "
        "(--checkpoint-minutes): run the same command again to resume"
    )
    assert checkpoint.exists()  # kept for the next run


def test_a_run_searches_on_the_cpus_it_was_given_unless_its_guidance_says(tmp_path, monkeypatch):
    from warehouse_phys.rl import fleet_planners

    path, given = str(tiny_instance(tmp_path)), []
    make = fleet_planners.planner_policy

    def planner_policy(name, seed=0, **guidance):
        given.append(guidance.get("workers"))
        return make(name, seed, **guidance)

    monkeypatch.setattr(fleet_planners, "planner_policy", planner_policy)
    rows = [run_job(Job("guided", path, 0, 8).to_dict(), threads=1),
            run_job(Job("guided", path, 0, 8, guidance={"workers": 3}).to_dict(), threads=1),
            run_job(Job("pibt", path, 0, 8).to_dict(), threads=1),
            run_job(Job("guided", path, 0, 8).to_dict())]  # fmt: skip
    assert given == [1, 3, None, None]  # None: the default, every core
    assert rows[0]["finished"] == rows[1]["finished"] == rows[3]["finished"]
