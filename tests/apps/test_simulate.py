"""python -m warehouse_phys.simulate: the measures, the run folder and clear errors."""

import json
import time
from pathlib import Path

import numpy as np
import pytest

from warehouse_phys.apps.simulate import POLICIES, build_parser, main
from warehouse_phys.apps.simulate.lockstep import simulate
from warehouse_phys.drawing.map_frames import MAP_PACKAGE, MAP_ROBOT_COLOURS, fleet_map_frame
from warehouse_phys.envs import fleet
from warehouse_phys.rl.fleet_planners import PLANNERS, TURNING_ONLY

#: The benchmark maps beside the repository (MovingAI), absent on a fresh clone.
MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def test_the_command_writes_its_run_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["--layout", "aisles", "--robots", "4", "--steps", "30", "--policy",
                 "shortest", "--frames", "4", "--out", str(out), "--quiet"]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "throughput" in printed
    assert "against the baselines" in printed  # 4 x 30 robot-steps: cheap
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["comparison"]) == {"shortest", "random"}
    assert summary["comparison"]["shortest"]["deliveries"] == summary["deliveries"]
    assert summary["steps"] == 30
    assert summary["policy"] == "shortest"
    assert len(summary["deliveries_per_step"]) == 30
    assert sorted(p.name for p in out.iterdir()) == [
        "congestion.png", "fleet.gif", "summary.json", "throughput.png"
    ]  # fmt: skip
    assert main(["--robots", "2", "--steps", "3", "--out", str(out), "--quiet",
                 "--policy", "random"]) == 2  # fmt: skip
    assert "--out" in capsys.readouterr().err


def test_the_guided_planner_is_chosen_by_name(tmp_path, capsys):
    out = tmp_path / "guided"
    assert main(["--layout", "warehouse", "--robots", "12", "--steps", "40", "--policy",
                 "guided", "--frames", "0", "--no-compare", "--out", str(out),
                 "--quiet"]) == 0  # fmt: skip
    assert capsys.readouterr().out.startswith("guided, 12 robots")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["policy"] == "guided"
    assert summary["refused"] == 0
    assert summary["deliveries"] > 0


def test_guidance_reaches_the_planner_and_is_recorded(tmp_path, capsys):
    # guided-paths is guided with the traffic prices at 0: set through --guidance on
    # guided, the same run, step for step; guided's own prices plan differently.
    def run(name, *guidance):
        out = tmp_path / f"{name}{len(guidance)}"
        argv = ["--layout", "warehouse", "--robots", "24", "--steps", "60", "--policy", name,
                *guidance, "--frames", "0", "--no-compare", "--out", str(out),
                "--quiet"]  # fmt: skip
        assert main(argv) == 0, capsys.readouterr().err
        return json.loads((out / "summary.json").read_text())

    paths = run("guided-paths")
    prices_off = run("guided", "--guidance", '{"vertex_weight": 0, "contraflow_weight": 0}')
    assert prices_off["deliveries_per_step"] == paths["deliveries_per_step"]
    assert prices_off["waits"] == paths["waits"]
    assert prices_off["guidance"] == {"vertex_weight": 0, "contraflow_weight": 0}
    guided = run("guided")
    assert "guidance" not in guided
    assert (guided["deliveries_per_step"], guided["waits"]) != (
        paths["deliveries_per_step"], paths["waits"]
    )  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--guidance", '{"reroute": 4}'],
         "--guidance sets a guided planner's fields; --policy pibt has none"),
        (["--policy", "shortest", "--guidance", '{"reroute": 4}'], "--policy shortest has none"),
        (["--policy", "guided", "--guidance", '{"reroute": -1}'],
         "--guidance: reroute must be >= 0, got -1"),
        (["--policy", "guided", "--guidance", '{"nope": 1}'],
         "--guidance: planner 'guided' has no field 'nope'"),
        (["--policy", "guided", "--guidance", "[1]"],
         "argument --guidance: expected a JSON object of planner fields"),
        (["--policy", "guided", "--guidance", "{"], "expected a JSON object of planner fields"),
        (["--policy", "guided", "--p-delay", "0.01", "--guidance", '{"nope": 4}'],
         "--guidance: planner 'guided' has no field 'nope'"),
    ],
)  # fmt: skip
def test_guidance_that_cannot_apply_ends_in_one_line(argv, message, capsys, tmp_path):
    assert main(["--robots", "2", "--steps", "3", *argv, "--out", str(tmp_path / "x"),
                 "--quiet"]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("name", PLANNERS)
def test_every_planner_runs_by_its_name(name, tmp_path, capsys):
    # PLANNERS is the planners' one list (rl/fleet_planners.py): a planner added there
    # runs here by its name, or this test fails. TURNING_ONLY's plan turning robots only.
    out = tmp_path / name
    turning = ["--moves", "rotate"] if name in TURNING_ONLY else []
    argv = ["--layout", "warehouse", "--robots", "8", "--steps", "12", "--policy", name,
            *turning, "--frames", "0", "--no-compare", "--out", str(out), "--quiet"]  # fmt: skip
    assert build_parser().parse_args(argv).policy == name
    assert main(argv) == 0, capsys.readouterr().err
    assert capsys.readouterr().out.startswith(f"{name}, 8 robots")
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["policy"], summary["refused"]) == (name, 0)
    assert name in POLICIES


@pytest.mark.parametrize("name", sorted(TURNING_ONLY))
def test_a_planner_of_turning_robots_without_them_ends_in_one_line(
    name, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    assert main(["--robots", "2", "--steps", "3", "--policy", name, "--quiet"]) == 2
    assert capsys.readouterr().err == (
        f"python -m warehouse_phys.simulate: error: policy {name!r} plans turning robots "
        "only: give --moves rotate\n"
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--policy", "magic"], "unknown policy 'magic': choose pibt, guided"),
        (["--robots", "300"], "300 robots need"),
        (["--layout", "nowhere"], "--layout 'nowhere' is neither a preset"),
        (["--on-delivery", "vanish"], "invalid choice: 'vanish'"),
        (["--layout", "aisles", "--rows", "5"], "not both"),
        (["--policy", "missing.npz"], "missing.npz"),
    ],
)
def test_bad_arguments_end_in_one_line(argv, message, capsys, tmp_path):
    assert main([*argv, "--out", str(tmp_path / "x"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_map_frames_show_robots_packages_and_shelves_in_array_colours():
    env = fleet.parallel_env(num_robots=3, layout="aisles")
    env.reset(seed=0)
    frame = fleet_map_frame(env.grid, env.robot_cells, env.package_cells, cell_px=6)
    assert frame.shape == (7 * 6, 9 * 6, 3)
    for i, (row, col) in enumerate(env.robot_cells.tolist()):
        assert (frame[row * 6, col * 6] == MAP_ROBOT_COLOURS[i]).all()
    for row, col in env.package_cells.tolist():
        assert (frame[row * 6 + 3, col * 6 + 3] == MAP_PACKAGE).all()
    # A package under a robot stays visible in the robot's middle.
    cells = np.array([[0, 0]])
    frame = fleet_map_frame(env.grid, cells, cells, cell_px=6)
    assert (frame[0, 0] == MAP_ROBOT_COLOURS[0]).all()
    assert (frame[3, 3] == MAP_PACKAGE).all()
    assert len({tuple(c) for c in MAP_ROBOT_COLOURS.tolist()}) == 8


def test_a_learned_table_drives_the_robots_and_a_policy_worse_than_a_baseline_is_named(
    tmp_path, capsys
):
    from warehouse_phys.rl.fleet_learning import fleet_table_metadata, new_fleet_q_table
    from warehouse_phys.rl.qlearning import QLearningConfig, save_q_table

    table = tmp_path / "qtable.npz"
    env = fleet.parallel_env(num_robots=2)
    metadata = fleet_table_metadata(env, QLearningConfig(), "warehouse-robot-v0")
    save_q_table(table, new_fleet_q_table(4, 5), metadata)  # all zeros: always LEFT
    argv = ["--robots", "2", "--steps", "40", "--policy", str(table), "--frames", "0",
            "--on-delivery", "park", "--out", str(tmp_path / "run"), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "WORSE: qtable.npz delivers a lower throughput" in printed
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert {"policy": "qtable.npz", "reference": "shortest"} in summary["worse_than"]
    assert not (tmp_path / "run" / "fleet.gif").exists()
    assert main([*argv[:-3], "--out", str(tmp_path / "again"), "--no-compare", "--quiet"]) == 0
    assert "against the baselines" not in capsys.readouterr().out


def test_a_malformed_map_ends_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.map"
    bad.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n")  # one row short
    assert main(["--layout", str(bad), "--out", str(tmp_path / "x"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "bad.map" in err
    assert err.count("\n") == 1
    assert main(["--layout", str(tmp_path / "none.map"), "--quiet"]) == 2
    assert "none.map" in capsys.readouterr().err


@pytest.mark.skipif(not (MAPS / "kiva-33-46.map").is_file(), reason=f"no benchmark maps in {MAPS}")
def test_the_kiva_warehouse_map_runs_the_planner(tmp_path, capsys):
    out = tmp_path / "kiva"
    argv = ["--layout", str(MAPS / "kiva-33-46.map"), "--robots", "64", "--steps", "8",
            "--frames", "3", "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    assert "pibt, 64 robots on kiva-33-46, 8 steps" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == 8
    assert summary["refused"] == 0  # the planner's plans are all granted
    from PIL import Image

    with Image.open(out / "fleet.gif") as gif:
        assert gif.size == (46 * 21, 33 * 21)  # the longer side fits 1000 px
        assert gif.n_frames == 3


def test_a_layout_text_file_runs_as_train_play_and_sweep_read_it(tmp_path, capsys):
    room = tmp_path / "room.txt"
    room.write_text(".......\n.##.##.\n.......\n.##.##.\n.......\n")
    out = tmp_path / "run"
    argv = ["--layout", str(room), "--robots", "3", "--steps", "10", "--frames", "2",
            "--no-compare", "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    assert "3 robots on room, 10 steps" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["layout"] == "room"
    assert len(summary["deliveries_per_step"]) == 10
    (tmp_path / "notes.txt").write_text("buy milk\n")
    assert main(["--layout", str(tmp_path / "notes.txt"), "--quiet",
                 "--out", str(tmp_path / "x")]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert f"--layout {tmp_path / 'notes.txt'}: unknown layout symbol 'b'" in err
    assert err.count("\n") == 1


def burn(seconds):
    """Spend ``seconds`` of CPU time."""
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def test_the_summary_times_the_reset_and_the_steps_with_the_frames_apart(tmp_path, monkeypatch):
    from warehouse_phys.drawing import map_frames as render

    drawn = render.fleet_map_frame
    reset = fleet.WarehouseFleetEnv.reset

    def slow_frame(*args, **kwargs):
        burn(0.03)
        return drawn(*args, **kwargs)

    def slow_reset(self, *args, **kwargs):
        burn(0.2)
        return reset(self, *args, **kwargs)

    monkeypatch.setattr(render, "fleet_map_frame", slow_frame)
    monkeypatch.setattr(fleet.WarehouseFleetEnv, "reset", slow_reset)
    out = tmp_path / "run"
    argv = ["--layout", "aisles", "--robots", "4", "--steps", "20", "--frames", "21",
            "--policy", "shortest", "--no-compare", "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    timing = json.loads((out / "summary.json").read_text())["cpu_seconds_of"]
    assert timing["reset"] >= 0.2
    assert timing["frames"] >= 21 * 0.03
    assert timing["median_frame"] >= 0.03
    # A frame after every step, none of it counted in a step.
    assert timing["first_step"] < 0.03
    assert timing["median_step"] <= timing["max_step"] < 0.03


# ------------------------------------------------------------------ instances
@pytest.mark.parametrize("moves", ["grid", "rotate"])
def test_an_instance_runs_with_its_published_figure_and_writes_the_competitions_file(
    tmp_path, capsys, moves
):
    from tests.envs.test_fleet_instances import small_instance
    from warehouse_phys.lorr.instances import write_instance
    from warehouse_phys.lorr.output import replay

    # Named as the 2024 record instance, so that its published figures are shown.
    path = write_instance(small_instance("scheduler", robots=6), tmp_path / "WAREHOUSE.json")
    out = tmp_path / "run"
    assert main(["--instance", str(path), "--moves", moves, "--steps", "30", "--out", str(out),
                 "--quiet", "--frames", "3", "--no-compare"]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert f"6 robots on WAREHOUSE, 30 steps (new_package, {moves} moves)" in printed
    assert "errands/step" in printed
    assert "tasks/step" in printed
    assert "published on WAREHOUSE: best known 30.97 tasks/step, default entry 12.78" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["instance"] == "WAREHOUSE"
    assert summary["moves"] == moves
    assert summary["errands"] == summary["deliveries"] >= summary["tasks"]
    assert summary["published"]["best_per_step"] == 30.97
    assert summary["scheduler"] == "rematch"  # the default
    timing = summary["cpu_seconds_of"]
    assert set(timing) == {"reset", "first_step", "median_step", "max_step", "frames",
                           "median_frame"}  # fmt: skip
    assert timing["max_step"] >= timing["median_step"] > 0
    output = json.loads((out / "lorr-output.json").read_text())
    assert output["numTaskFinished"] == summary["tasks"]
    grid = fleet.parallel_env(instance=path).grid
    assert replay(output, grid).conflicts == []


def test_the_scheduler_is_chosen_by_name_and_only_for_an_instance(tmp_path, capsys):
    from tests.envs.test_fleet_instances import small_instance
    from warehouse_phys.apps.simulate import _setup, build_parser
    from warehouse_phys.lorr.instances import write_instance
    from warehouse_phys.lorr.scheduling import least_makespan
    from warehouse_phys.lorr.scheduling_assignment import AssignmentScheduler
    from warehouse_phys.lorr.station_cap import STATION_CAP

    path = write_instance(small_instance("scheduler", robots=4), tmp_path / "w.json")
    for argv, rematch, cap in (([], True, None), (["--scheduler", "rematch"], True, None),
                               (["--scheduler", "rematch-capped"], True, STATION_CAP),
                               (["--scheduler", "assignment"], False, None)):  # fmt: skip
        env, _ = _setup(build_parser().parse_args(["--instance", str(path), *argv]))
        assert isinstance(env.errands.scheduler, AssignmentScheduler)
        assert env.errands.scheduler.rematch is rematch
        assert env.errands.scheduler.station_cap == cap
    env, _ = _setup(build_parser().parse_args(["--instance", str(path), "--scheduler",
                                               "makespan"]))  # fmt: skip
    assert env.errands.scheduler is least_makespan
    assert main(["--scheduler", "makespan", "--out", str(tmp_path / "r")]) == 2
    assert "--scheduler hands out an instance's tasks: give --instance" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_what_a_run_does_not_model_is_said_in_its_output_and_summary(tmp_path, capsys):
    """A 2026 instance runs on its ticks and delays (tests/apps/test_simulate_async.py);
    what that run does not model (turning robots, LoRR's square robots) is said in the
    output and in summary.json, rather than passed over, and the lock-step fleet of such an
    instance, built in Python, says that it leaves out the ticks and delays."""
    import dataclasses

    from tests.envs.test_fleet_instances import small_instance
    from warehouse_phys.execution.delays import DelayConfig
    from warehouse_phys.lorr.instances import write_instance
    from warehouse_phys.rl.fleet_planners import pibt_policy

    delay = DelayConfig(7, 1, 20, "bernoulli", 0.005, "uniform")
    plain = small_instance("scheduler", robots=4)
    timed = dataclasses.replace(plain, version="2026 LoRR", agent_counter=10, delay=delay)
    notes = {}
    for name, instance in {"plain": plain, "timed": timed}.items():
        path = write_instance(instance, tmp_path / f"{name}.json")
        out = tmp_path / name
        assert main(["--instance", str(path), "--steps", "5", "--out", str(out), "--quiet",
                     "--frames", "0", "--no-compare"]) == 0  # fmt: skip
        printed = capsys.readouterr().out
        notes[name] = json.loads((out / "summary.json").read_text())["not_simulated"]
        assert [line for line in printed.splitlines() if line.startswith("not simulated")] == [
            f"not simulated: {note}" for note in notes[name]
        ]
    assert notes["plain"] == []
    # A 2026 instance runs by the start kit's rules (turning robots, squares): only time
    # is left out, the kit's real-time rounds.
    assert [note.split(":")[0] for note in notes["timed"]] == ["time"]
    env = fleet.parallel_env(instance=timed, record_errands=True)
    result, _ = simulate(env, pibt_policy(0), steps=2)
    assert result.not_simulated == (
        "agentCounter (10 ticks an action): here an action takes one step",
        "delayConfig (pDelay 0.005): here no delays",
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--layout", "aisles"], "an instance gives the floor, the robots and their errands; "
                                 "do not give --layout"),
        (["--robots", "3"], "do not give --robots"),
        (["--moves", "hop"], "invalid choice: 'hop'"),
        (["--scheduler", "makespan"], "--scheduler: x assigns its tasks 'roundrobin' (LoRR "
                                      "2023), without a scheduler"),
        (["--scheduler", "fastest"], "invalid choice: 'fastest'"),
    ],
)  # fmt: skip
def test_bad_instance_arguments_end_in_one_line(tmp_path, capsys, argv, message):
    from tests.envs.test_fleet_instances import small_instance
    from warehouse_phys.lorr.instances import write_instance

    path = write_instance(small_instance(), tmp_path / "x.json")
    assert main(["--instance", str(path), "--out", str(tmp_path / "run"), *argv]) == 2
    error = capsys.readouterr().err
    assert message in error
    assert error.count("\n") == 1
    (tmp_path / "bad.json").write_text('{"taskAssignmentStrategy": "greedy", "teamSize": 3}')
    assert main(["--instance", str(tmp_path / "bad.json"), "--out", str(tmp_path / "r")]) == 2
    assert "bad.json: missing 'mapFile'" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()
