"""python -m warehouse_phys.simulate on ticks: LoRR 2026's agentCounter and delayConfig
honoured, their measures and output file, the tick flags on a plain floor, clear refusals."""

import dataclasses
import json
from pathlib import Path

import pytest

from tests.envs.test_fleet_instances import small_instance
from warehouse_phys.apps.simulate import main
from warehouse_phys.apps.simulate.on_ticks import DEFAULT_DELAYS
from warehouse_phys.execution.delays import DelayConfig, DelayGenerator
from warehouse_phys.lorr.instances import read_instance, write_instance
from warehouse_phys.lorr.output import replay
from warehouse_phys.lorr.output_2026 import KEYS, read_output, walk

LORR = Path(__file__).resolve().parents[3] / "shared" / "lorr"
MAZE = LORR / "2026-examples-maze" / "maze-example_40.json"
TICKS = 300
MEASURES = {"own_delay_share", "knock_on_share", "held_share", "delayed_share",
            "mean_drift_ticks", "plans", "min_gap"}  # fmt: skip
needs_maze = pytest.mark.skipif(
    not MAZE.is_file(),
    reason=f"no LoRR 2026 instances in {LORR} (data, not part of the repository: see "
    "../shared/lorr/README.md)",
)


def run(tmp_path, name, *argv):
    """Run the command quietly, no frames, into ``tmp_path / name``; its summary and
    output file (``None`` where it wrote none)."""
    out = tmp_path / name
    assert main([*argv, "--out", str(out), "--quiet", "--frames", "0", "--no-compare"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    output = out / "lorr-output.json"
    return summary, json.loads(output.read_text()) if output.exists() else None


def drawn(config, robots, ticks):
    """LoRR's delayIntervals of ``config`` for ``robots`` over ``ticks`` ticks."""
    generator = DelayGenerator(config, robots)
    for _ in range(ticks):
        generator.next_tick()
    return generator.intervals_json()


@needs_maze
def test_a_2026_instance_runs_by_the_start_kits_rules_and_writes_its_2026_output(tmp_path, capsys):
    instance = read_instance(MAZE)
    summary, output = run(tmp_path, "a", "--instance", str(MAZE), "--steps", str(TICKS))
    printed = capsys.readouterr().out
    assert (f"pibt, 40 robots on maze-example_40, {TICKS} ticks by the start kit's rules (3 "
            "ticks a move or turn, squares of side 1, a plan every 10 ticks, pDelay 0.0003") \
        in printed  # fmt: skip
    assert "0 square collisions by the kit's rule, 0 schedule errors" in printed
    # The kit's 2026 output: its keys, its segments, the delay generator's draws.
    assert list(output) == list(KEYS)
    assert output["agentMaxCounter"] == instance.agent_counter == 3
    assert output["outputSegmentSize"] == 100
    assert output["makespan"] == TICKS
    intervals = output["delayIntervals"]
    assert intervals == drawn(instance.delay, 40, TICKS)
    assert any(intervals)
    assert all(5 <= end - start <= 12 for robot in intervals for start, end in robot)
    read = read_output(tmp_path / "a" / "lorr-output.json")
    assert read.actual.shape == (40, TICKS)
    assert walk(read, instance.grid).collisions == []
    assert output["numTaskFinished"] == summary["tasks"]
    assert output["numPlannerErrors"] == 0
    # The summary: the rates a tick, the kit's rules.
    assert (summary["time_unit"], summary["rules"], summary["ticks"]) == (
        "tick",
        "start kit",
        TICKS,
    )
    assert summary["delay_config"] == instance.delay.to_json()
    assert summary["delays_drawn"] == sum(map(len, intervals))
    assert summary["square_collisions"] == 0
    assert summary["errands_per_tick"] == summary["errands"] / TICKS
    # Bit-identical in a second run: --delays-from replays every interval of the first.
    # The delays are the generator's own draws (above), so a second plain run would only
    # repeat this one; the replay is a second run in the same process all the same.
    first = str(tmp_path / "a" / "lorr-output.json")
    _, replayed = run(tmp_path, "c", "--instance", str(MAZE), "--steps", str(TICKS),
                      "--p-delay", "0.2", "--delays-from", first)  # fmt: skip
    for key in ("delayIntervals", "actualPaths", "events", "tasks"):
        assert replayed[key] == output[key]


@needs_maze
def test_p_delay_and_delay_seed_replace_the_instances_pdelay_and_seed_alone(tmp_path):
    instance = read_instance(MAZE)
    summary, output = run(tmp_path, "run", "--instance", str(MAZE), "--steps", "60",
                          "--p-delay", "0.05", "--delay-seed", "9")  # fmt: skip
    config = dataclasses.replace(instance.delay, p_delay=0.05, seed=9)
    assert summary["delay_config"] == config.to_json()
    assert output["delayIntervals"] == drawn(config, 40, 60) != drawn(instance.delay, 40, 60)
    assert output["agentMaxCounter"] == 3
    _, faster = run(tmp_path, "fast", "--instance", str(MAZE), "--steps", "30",
                    "--ticks-per-move", "2")  # fmt: skip
    assert faster["agentMaxCounter"] == 2


def test_the_station_cap_runs_by_the_start_kits_rules(tmp_path, capsys):
    """--scheduler rematch-capped by the kit's rules: the entry's assignment-capped, whose
    robots go otherwise than rematching's where more robots than the cap head for a
    station."""
    from tests.lorr.tiny_kit_instance import station_instance

    path = write_instance(station_instance(), tmp_path / "stations.json")
    runs = {}
    for scheduler in ("rematch", "rematch-capped"):
        summary, output = run(tmp_path, scheduler, "--instance", str(path), "--steps", "120",
                              "--scheduler", scheduler)  # fmt: skip
        assert "0 square collisions by the kit's rule, 0 schedule errors" in capsys.readouterr().out
        assert summary["rules"] == "start kit"
        assert output["numTaskFinished"] == summary["tasks"] > 0
        runs[scheduler] = output["actualPaths"]
    assert runs["rematch"] != runs["rematch-capped"]


def test_guidance_sets_the_entrys_planner_by_the_start_kits_rules(tmp_path, capsys):
    """--guidance on a run by the kit's rules: the entry's planner takes the fields (its
    robots go otherwise) and summary.json records them."""
    from tests.lorr.tiny_kit_instance import station_instance

    path = write_instance(station_instance(), tmp_path / "stations.json")
    guidance = {"vertex_weight": 2.0, "iterations": 0}
    argv = ["--instance", str(path), "--steps", "120", "--policy", "guided-ops-repair"]
    plain, plain_output = run(tmp_path, "plain", *argv)
    summary, output = run(tmp_path, "guided", *argv, "--guidance", json.dumps(guidance))
    assert "0 square collisions by the kit's rule" in capsys.readouterr().out
    assert (summary["rules"], summary["guidance"]) == ("start kit", guidance)
    assert "guidance" not in plain
    assert output["actualPaths"] != plain_output["actualPaths"]


def test_ticks_on_an_earlier_instance_write_empty_delay_intervals_and_replay(tmp_path, capsys):
    """--ticks-per-move on a 2024 instance: the same output, plus agentMaxCounter and one
    empty list of delays a robot; the paths replay tick by tick without a conflict."""
    path = write_instance(small_instance("scheduler", robots=6), tmp_path / "small.json")
    summary, output = run(tmp_path, "run", "--instance", str(path), "--ticks-per-move", "4",
                          "--steps", "120", "--moves", "grid")  # fmt: skip
    assert "120 ticks (4 ticks a move, no delays, grid moves)" in capsys.readouterr().out
    assert output["agentMaxCounter"] == 4
    assert output["delayIntervals"] == [[]] * 6
    assert list(output)[:5] == ["actionModel", "AllValid", "teamSize", "agentMaxCounter",
                                "delayIntervals"]  # fmt: skip
    assert summary["errands"] > 0
    assert summary["delay_config"] is None
    assert replay(output, read_instance(path).grid).conflicts == []


def test_the_tick_flags_run_a_plain_floor(tmp_path, capsys):
    flags = ["--ticks-per-move", "3", "--p-delay", "0.05", "--delay-seed", "1"]
    summary, output = run(tmp_path, "run", "--layout", "aisles", "--robots", "4", *flags)
    printed = capsys.readouterr().out
    assert "4 robots on aisles, 768 ticks (3 ticks a move, pDelay 0.05 (bernoulli), delays of " \
        "1-20 ticks (uniform), seed 1, grid moves)" in printed  # fmt: skip
    assert "deliveries/tick" in printed
    assert "against the baselines" not in printed
    assert output is None  # no instance, no competition file
    assert summary["ticks"] == 256 * 3  # 256 moves' worth by default
    assert summary["delay_config"] == dataclasses.replace(DEFAULT_DELAYS, p_delay=0.05,
                                                          seed=1).to_json()  # fmt: skip
    assert summary["deliveries"] > 0
    assert summary["delays_drawn"] > 0
    assert summary["deliveries_per_move"] == pytest.approx(3 * summary["deliveries"] / 768)
    assert set(summary["execution"]) == MEASURES
    assert "comparison" not in summary


def test_turning_robots_run_on_ticks_on_a_floor_and_the_guided_planner_too(tmp_path, capsys):
    """LoRR's robot model on a floor of our own: forward moves and quarter turns each take
    the move's ticks, robots as discs (our model); the guided planner runs on ticks."""
    for policy in ("pibt", "guided"):
        summary, output = run(tmp_path, policy, "--layout", "aisles", "--robots", "4",
                              "--moves", "rotate", "--ticks-per-move", "3", "--steps", "150",
                              "--p-delay", "0.05", "--policy", policy)  # fmt: skip
        printed = capsys.readouterr().out
        assert f"{policy}, 4 robots on aisles, 150 ticks" in printed
        assert "rotate moves" in printed
        assert output is None
        assert summary["deliveries"] > 0


def test_guidance_sets_the_windows_planner_on_ticks(tmp_path, capsys):
    """--guidance on the fleet on ticks (a floor): the windows' guided planner takes the
    fields, its robots go otherwise, and summary.json records them."""
    argv = ["--layout", "warehouse", "--robots", "24", "--ticks-per-move", "2", "--steps",
            "200", "--policy", "guided"]  # fmt: skip
    plain, _ = run(tmp_path, "plain", *argv)
    guidance = {"vertex_weight": 0, "contraflow_weight": 0}
    summary, _ = run(tmp_path, "priced", *argv, "--guidance", json.dumps(guidance))
    capsys.readouterr()
    assert summary["guidance"] == guidance
    assert "guidance" not in plain
    assert summary["deliveries"] > 0
    assert summary["deliveries_per_step"] != plain["deliveries_per_step"]


@needs_maze
def test_replayed_delays_must_come_from_an_output_file_of_the_instance(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    short = {"teamSize": 40, "delayIntervals": [[]] * 40, "makespan": 10}
    cases = [
        ("{", "Expecting property name"),
        (
            json.dumps({"teamSize": 3, "delayIntervals": [[], [], []]}),
            "3 robots, maze-example_40 has 40",
        ),
        (json.dumps(short), "it covers 10 ticks, --steps asks for 300"),
    ]
    for text, message in cases:
        bad.write_text(text)
        assert main(["--instance", str(MAZE), "--steps", str(TICKS), "--delays-from", str(bad),
                     "--out", str(tmp_path / "x"), "--quiet"]) == 2  # fmt: skip
        assert message in capsys.readouterr().err
    assert main(["--instance", str(MAZE), "--moves", "grid", "--delays-from", str(bad),
                 "--out", str(tmp_path / "y"), "--quiet"]) == 2  # fmt: skip
    assert "--delays-from replays a start-kit run's delays" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("where", "argv", "message"),
    [
        ("instance", ["--policy", "shortest"], "--policy shortest: a run on ticks"),
        ("instance", ["--scheduler", "assignment"], "the entry's assignment pairs again"),
        ("floor", ["--on-delivery", "park", "--p-delay", "0.1"], "is lifelong (new_package)"),
        ("floor", ["--delay-seed", "3"], "--delay-seed needs delays: give --p-delay too"),
        ("floor", ["--p-delay", "nan"], "expected a chance from 0 to 1, got nan"),
    ],
)  # fmt: skip
def test_what_ticks_do_not_model_is_refused_in_one_line(tmp_path, capsys, where, argv, message):
    delays = DelayConfig(7, 1, 20, "bernoulli", 0.005, "uniform")
    timed = dataclasses.replace(small_instance("scheduler", robots=4), version="2026 LoRR",
                                agent_counter=10, delay=delays)  # fmt: skip
    if where == "floor":
        argv = ["--layout", "aisles", *argv]
    else:
        argv = ["--instance", str(write_instance(timed, tmp_path / "timed.json")), *argv]
    assert main([*argv, "--out", str(tmp_path / "run")]) == 2
    error = capsys.readouterr().err
    assert message in error
    assert error.count("\n") == 1
    assert not (tmp_path / "run").exists()


def test_every_planner_runs_on_ticks_and_one_of_turning_robots_needs_them(tmp_path, capsys):
    floor = ["--layout", "aisles", "--robots", "4", "--ticks-per-move", "3"]
    summary, _ = run(tmp_path, "ops", *floor, "--moves", "rotate", "--steps", "60",
                     "--policy", "guided-ops")  # fmt: skip
    assert summary["policy"] == "guided-ops"
    assert main([*floor, "--moves", "grid", "--policy", "guided-ops", "--out",
                 str(tmp_path / "x"), "--quiet"]) == 2  # fmt: skip
    assert "--policy guided-ops plans turning robots only: give --moves rotate" in (
        capsys.readouterr().err
    )
