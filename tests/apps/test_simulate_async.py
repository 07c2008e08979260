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
from warehouse_phys.lorr.output import GRID_LETTERS, replay

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
def test_a_2026_instance_runs_on_its_ticks_and_writes_its_delay_intervals(tmp_path, capsys):
    instance = read_instance(MAZE)
    summary, output = run(tmp_path, "a", "--instance", str(MAZE), "--steps", str(TICKS))
    printed = capsys.readouterr().out
    assert f"40 robots on maze-example_40, {TICKS} ticks (3 ticks a move, pDelay 0.0003" in printed
    for measure in ("errands/tick", "tasks/tick", "a move", "own delay", "knock-on", "mean drift"):
        assert measure in printed
    # The output: LoRR's agentCounter and the delay generator's draws, one letter a tick.
    assert output["agentMaxCounter"] == instance.agent_counter == 3
    intervals = output["delayIntervals"]
    assert intervals == drawn(instance.delay, 40, TICKS)
    assert len(intervals) == 40
    assert any(intervals)
    assert all(5 <= end - start <= 12 for robot in intervals for start, end in robot)
    assert all(len(path.split(",")) == TICKS for path in output["actualPaths"])
    assert set(",".join(output["actualPaths"]).split(",")) <= set(GRID_LETTERS)
    assert len(output["plannerTimes"]) == summary["execution"]["plans"] == TICKS // 3
    assert output["numTaskFinished"] == summary["tasks"]
    assert replay(output, instance.grid).conflicts == []
    # The summary: the rates a tick and a move, the shares, no note on ticks or delays.
    assert summary["time_unit"] == "tick"
    assert summary["ticks"] == summary["steps"] == TICKS
    assert summary["ticks_per_move"] == 3
    assert summary["delay_config"] == instance.delay.to_json()
    assert summary["delays_drawn"] == sum(map(len, intervals))
    assert set(summary["execution"]) == MEASURES
    assert summary["errands_per_tick"] == summary["errands"] / TICKS
    assert summary["errands_per_move"] == pytest.approx(3 * summary["errands_per_tick"])
    assert summary["tasks_per_move"] == pytest.approx(3 * summary["tasks"] / TICKS)
    assert not any("agentCounter (" in note for note in summary["not_simulated"])
    # Bit-identical in a second run.
    again, repeated = run(tmp_path, "b", "--instance", str(MAZE), "--steps", str(TICKS))
    for key in ("delayIntervals", "actualPaths", "events", "tasks"):
        assert repeated[key] == output[key]
    assert again["execution"] == summary["execution"]


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


def test_ticks_on_an_earlier_instance_write_empty_delay_intervals_and_replay(tmp_path, capsys):
    """--ticks-per-move on a 2024 instance: the same output, plus agentMaxCounter and one
    empty list of delays a robot; the paths replay tick by tick without a conflict."""
    path = write_instance(small_instance("scheduler", robots=6), tmp_path / "small.json")
    summary, output = run(tmp_path, "run", "--instance", str(path), "--ticks-per-move", "4",
                          "--steps", "120")  # fmt: skip
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


@needs_maze
def test_turning_robots_run_on_ticks_and_their_output_replays(tmp_path, capsys):
    """LoRR's own robot model on its 2026 instance: forward moves and quarter turns each
    take agentCounter ticks; the output is MAPF_T, a letter a tick, and replays."""
    instance = read_instance(MAZE)
    summary, output = run(tmp_path, "t", "--instance", str(MAZE), "--steps", str(TICKS),
                          "--moves", "rotate")  # fmt: skip
    printed = capsys.readouterr().out
    assert "rotate moves" in printed
    assert "turning robots" not in " ".join(summary["not_simulated"])
    assert output["actionModel"] == "MAPF_T"
    assert output["agentMaxCounter"] == instance.agent_counter
    paths = [path.split(",") for path in output["actualPaths"]]
    assert all(len(path) == TICKS for path in paths)
    assert {"R", "C"} & {letter for path in paths for letter in path}  # robots turned
    replayed = replay(output, instance.grid)
    assert replayed.conflicts == []
    assert summary["errands"] > 0


@pytest.mark.parametrize(
    ("where", "argv", "message"),
    [
        ("instance", ["--policy", "shortest"], "--policy shortest: a run on ticks"),
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
