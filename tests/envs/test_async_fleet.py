"""The asynchronous fleet: PettingZoo's suites, the physics twin against the grid twin
tick by tick (no contact, the same cells), holds as safe as delays, LoRR 2026 instances,
10,000 bodies on two threads, clear refusals (the bodies' cap: this machine's memory)."""

import functools
import warnings
from pathlib import Path

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from warehouse_phys.envs import async_fleet, lorr
from warehouse_phys.execution.async_grid import AsyncGrid
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.physics import COLLISION_SLOP, HEADING_SNAP_BOUND
from warehouse_phys.physics.tick_controller import check_tick_controller
from warehouse_phys.physics.ticking import TRACKING_MARGIN

LORR = Path(__file__).resolve().parents[3] / "shared" / "lorr"
FLOOR = ["S.......", ".##.##..", "........", ".##.##..", "........"]
DELAYS = DelayConfig(seed=1, min_delay=1, max_delay=8, event_model="bernoulli", p_delay=0.03,
                     duration_model="uniform")  # fmt: skip


def quietly(test, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        test(*args, **kwargs)


@pytest.mark.parametrize(("physics", "moves"), [(False, "grid"), (True, "grid"),
                                               (False, "rotate"), (True, "rotate")])  # fmt: skip
def test_pettingzoos_parallel_and_aec_suites_pass(physics, moves):
    kwargs = {"layout": FLOOR, "num_robots": 4, "ticks_per_move": 3, "delays": DELAYS,
              "max_cycles": 40, "physics": physics, "moves": moves}  # fmt: skip
    quietly(parallel_api_test, async_fleet.parallel_env(**kwargs), num_cycles=60)
    quietly(parallel_seed_test, functools.partial(async_fleet.parallel_env, **kwargs), 30)
    quietly(api_test, async_fleet.env(**kwargs), num_cycles=30)


def run_both(seed, ticks, **kwargs):
    """The grid and physics twins under the same random GO/STOP actions, tick by tick:
    the physics twin's bodies stay within the controller's tracking error of the grid
    twin's centres, end their moves on its cells, and never touch."""
    body = async_fleet.parallel_env(physics=True, track_gaps=True, **kwargs)
    grid = async_fleet.parallel_env(min_gap=body.min_gap, **kwargs)  # the bodies' gap
    grid.reset(seed=seed)
    body.reset(seed=seed)
    rng = np.random.default_rng(seed)
    motion = check_tick_controller(body.physics, int(body.execution.executor.ticks_needed.min()),
                                   body.tick_steps, turning=body.turning)  # fmt: skip
    diameter = body.physics.robot_diameter
    twin = AsyncGrid(body.grid, body.execution.executor.left, body.execution.executor.ticks_needed)
    errands = 0
    for _ in range(ticks):
        actions = {agent: int(rng.random() < 0.9) for agent in grid.agents}
        _, rewards, _, _, _ = grid.step(actions)
        _, body_rewards, _, _, infos = body.step(actions)
        report = body.execution.executor
        twin.left[:], twin.entered[:], twin.done[:] = report.left, report.entered, report.done
        assert (grid.execution.executor.left == report.left).all()
        assert (grid.execution.executor.done == report.done).all()
        assert rewards == body_rewards
        errands += sum(rewards.values())
        off = np.linalg.norm(body.world.positions() - twin.centres(), axis=1)
        assert off.max() <= motion.tracking_error + TRACKING_MARGIN
        assert body.closest_approach() >= diameter - COLLISION_SLOP
        assert max(info["snap_error"] for info in infos.values()) < 0.02
        if body.turning:  # the bodies face the grid twin's headings, turns end on them
            assert (body.world.headings == report.headings).all()
            assert np.all(body.world.heading_errors < HEADING_SNAP_BOUND)
    return errands


SPEEDS = [1, 2, 1.5, 1] * 3 + [1, 1]


@pytest.mark.parametrize(("seed", "ticks_per_move", "speeds", "moves"),
                         [(0, 3, None, "grid"), (1, 10, None, "grid"), (2, 4, SPEEDS, "grid"),
                          (3, 3, None, "rotate"), (4, 4, SPEEDS, "rotate")])  # fmt: skip
def test_the_physics_twin_follows_the_grid_twin_and_bodies_never_touch(
    seed, ticks_per_move, speeds, moves
):
    errands = run_both(seed, 100, layout=FLOOR, num_robots=14, ticks_per_move=ticks_per_move,
                       speeds=speeds, delays=DELAYS, moves=moves)  # fmt: skip
    assert errands > 0


def test_holding_every_robot_stops_the_fleet_and_counts_as_held():
    env = async_fleet.parallel_env(layout=FLOOR, num_robots=6, ticks_per_move=2)
    env.reset(seed=0)
    cells = env.execution.executor.left.copy()
    for _ in range(5):
        _, rewards, _, _, infos = env.step(dict.fromkeys(env.agents, async_fleet.STOP))
        assert not any(rewards.values())
    assert (env.execution.executor.left == cells).all()
    assert all(info["held"] for info in infos.values())
    assert env.execution.measures.held > 0
    assert env.execution.measures.knock_on == 0


def test_a_lifelong_fleet_delivers_and_the_same_seed_gives_the_same_run():
    def run():
        env = async_fleet.parallel_env(layout=FLOOR, num_robots=8, ticks_per_move=3,
                                       delays=DELAYS, max_cycles=200,
                                       around_delays="reroute")  # fmt: skip
        observations, _ = env.reset(seed=5)
        trace = []
        while env.agents:
            observations, _, _, truncations, _ = env.step(dict.fromkeys(env.agents, 1))
            trace.append(np.stack(list(observations.values())))
        return env.errands_done, np.stack(trace), truncations

    first, second = run(), run()
    assert first[0] > 5
    assert first[0] == second[0]
    assert (first[1] == second[1]).all()
    assert all(first[2].values())


@pytest.mark.skipif(not (LORR / "2026-examples-maze").is_dir(),
                    reason=f"the LoRR instances are not in {LORR}")  # fmt: skip
@pytest.mark.parametrize("moves", ["grid", "rotate"])
def test_a_2026_instance_runs_with_its_ticks_and_delays(moves):
    env = lorr.async_fleet(
        LORR / "2026-examples-maze" / "maze-example_40.json", moves=moves, max_cycles=400
    )
    observations, _ = env.reset(seed=0)
    assert len(observations["robot_0"]) == (12 if moves == "rotate" else 10)
    instance = env.instance
    assert (env.execution.executor.ticks_needed == instance.agent_counter).all()
    assert env.delays == instance.delay
    while env.agents:
        env.step(dict.fromkeys(env.agents, 1))
    assert env.errands.errands_done == env.errands_done > 0
    assert env.execution.measures.delayed > 0


def test_bad_arguments_and_actions_are_refused_in_one_line():
    with pytest.raises(TypeError, match="need physics=True"):
        async_fleet.parallel_env(layout=FLOOR, robot_radius=0.2)
    with pytest.raises(ValueError, match=r"less than the .* these bodies need"):
        async_fleet.parallel_env(layout=FLOOR, physics=True, min_gap=0.3)
    with pytest.raises(ValueError, match="tick_steps is for the physics twin"):
        async_fleet.parallel_env(layout=FLOOR, tick_steps=3)
    with pytest.raises(TypeError, match="delays must be"):
        async_fleet.parallel_env(layout=FLOOR, delays="often")
    with pytest.raises(ValueError, match="around_delays must be one of"):
        async_fleet.parallel_env(layout=FLOOR, around_delays="dodge")
    env = async_fleet.parallel_env(layout=FLOOR, num_robots=2)
    env.reset(seed=0)
    for actions, error in [({"robot_0": 1}, ValueError), ({"robot_0": 2, "robot_1": 1},
                           ValueError), ({"robot_0": 1.0, "robot_1": 1}, TypeError)]:  # fmt: skip
        with pytest.raises(error, match="robot_"):
            env.step(actions)
    assert env.ticks == 0  # nothing was run


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"min_gap": "0.7"}, TypeError, "min_gap must be a real number of cells, got '0.7'"),
        ({"min_gap": b"0.7"}, TypeError, "min_gap must be a real number"),
        ({"min_gap": True}, TypeError, "min_gap must be a real number"),
        ({"min_gap": 0.5 + 0j}, TypeError, "min_gap must be a real number"),
        ({"min_gap": [0.7]}, TypeError, "min_gap must be a real number"),
        ({"min_gap": 10**400}, ValueError, r"min_gap must be in \(0, 1\] cells, got an integer"),
        ({"min_gap": float("nan")}, ValueError, r"min_gap must be in \(0, 1\] cells, got nan"),
        ({"seed": "1"}, TypeError, "seed must be an integer, got '1'"),
        ({"seed": b"1"}, TypeError, "seed must be an integer"),
        ({"seed": False}, TypeError, "seed must be an integer"),
        ({"seed": 1j}, TypeError, "seed must be an integer"),
        ({"seed": [1]}, TypeError, "seed must be an integer"),
        ({"seed": 10**400}, ValueError, r"seed must be 0 to 9,223,372,036,854,775,807, got an "
                                        r"integer of 401 digits"),
        ({"seed": -1}, ValueError, "seed must be 0 to"),
        ({"num_robots": 10**400}, ValueError, r"^num_robots must be 1 to 1,000,000, got an "
                                              r"integer of 401 digits$"),
        ({"physics_threads": 0}, ValueError, "threads must be from 1 to 64"),
        ({"planner": "guided", "guidance": {"nope": 1}}, TypeError,
         "planner 'guided' has no field 'nope'; its fields: vertex_weight"),
        ({"planner": "guided", "guidance": {"reroute": -1}}, ValueError, "reroute must be >= 0"),
        ({"guidance": {"reroute": 1}}, ValueError, "plain PIBT takes no guidance"),
        ({"planner": "guided", "guidance": [1]}, TypeError,
         "guidance must be a mapping of a guided planner's fields, got list"),
    ],
)  # fmt: skip
def test_the_async_fleets_own_arguments_are_refused_by_name(kwargs, error, message):
    with pytest.raises(error, match=message):
        async_fleet.parallel_env(layout=FLOOR, **kwargs)


@pytest.mark.parametrize("action", [np.timedelta64(1), np.timedelta64(1, "s"), True, 1.0, "1",
                                    None, np.ma.masked, 2, -1, 10**400])  # fmt: skip
def test_a_bad_action_is_refused_naming_the_robot_and_nothing_changes(action):
    env = async_fleet.parallel_env(layout=FLOOR, num_robots=2)
    env.reset(seed=0)
    with pytest.raises((TypeError, ValueError), match=r"^robot_1's action .*(STOP|masked)"):
        env.step({"robot_0": 1, "robot_1": action})
    assert env.ticks == 0
    aec = async_fleet.env(layout=FLOOR, num_robots=2)
    aec.reset(seed=0)
    aec.step(1)  # robot_0's: fine
    with pytest.raises((TypeError, ValueError), match=r"^robot_1's action"):
        aec.step(action)  # refused at once, not stored to fail later
    assert aec.agent_selection == "robot_1"
    aec.step(1)  # the episode goes on
    aec.step(1)
    assert aec.unwrapped.ticks == 1


def test_the_aec_form_refuses_the_battery_s_seven_at_once_and_keeps_stepping():
    aec = async_fleet.env(layout=FLOOR, num_robots=3)
    aec.reset(seed=0)
    with pytest.raises(ValueError, match=r"robot_0's action must be 0 \(STOP\) or 1 \(GO\), got 7"):
        aec.step(7)
    for _ in range(9):  # three whole ticks, no error from the last robot's turn on
        aec.step(1)
    assert aec.unwrapped.ticks == 3


def test_reset_refuses_options_it_does_not_know_but_lets_pettingzoos_probe_through():
    env = async_fleet.parallel_env(layout=FLOOR, num_robots=2)
    with pytest.raises(ValueError, match=r"unknown reset option\(s\) 'x'; known: 'delays'"):
        env.reset(options={"x": 1})
    with pytest.raises(TypeError, match="reset options must be a dict or None"):
        env.reset(options=[("delays", None)])
    env.reset(seed=0, options={"options": 1})  # PettingZoo's API test passes this
    env.reset(seed=0, options={"delays": None})
    assert env.delays is None


@pytest.mark.parametrize(("physics", "moves", "threads"),
                         [(False, "grid", 1), (True, "grid", 1), (True, "rotate", 2)])  # fmt: skip
def test_the_array_form_runs_the_same_episode_as_the_dicts(physics, moves, threads):
    kwargs = {"layout": FLOOR, "num_robots": 8, "ticks_per_move": 3, "delays": DELAYS,
              "max_cycles": 60, "physics": physics, "moves": moves}  # fmt: skip
    if physics:
        kwargs["physics_threads"] = threads
    dicts, arrays = async_fleet.parallel_env(**kwargs), async_fleet.parallel_env(**kwargs)
    observations, infos = dicts.reset(seed=4)
    table, columns = arrays.reset_arrays(seed=4)
    rng = np.random.default_rng(4)
    while dicts.agents:
        assert np.array_equal(np.stack(list(observations.values())), table)
        for key, column in columns.items():
            assert [info[key] for info in infos.values()] == column.tolist(), key
        actions = (rng.random(8) < 0.9).astype(np.int64)
        observations, rewards, terminations, truncations, infos = dicts.step(
            dict(zip(dicts.agents, actions.tolist(), strict=True)))  # fmt: skip
        step = arrays.step_arrays(actions)
        table, columns = step.observations, step.infos
        assert list(rewards.values()) == step.rewards.tolist()
        assert list(terminations.values()) == step.terminations.tolist()
        assert list(truncations.values()) == step.truncations.tolist()
    assert not arrays.agents
    assert arrays.errands_done == dicts.errands_done > 0
    if physics:
        assert arrays.safety.summary() == dicts.safety.summary()
        assert {"closest_approach", "body_contacts", "wall_contacts"} <= set(infos["robot_0"])
        assert dicts.safety.body_contacts == dicts.safety.wall_contacts == 0
        assert dicts.safety.closest_approach >= dicts.safety.bound
        arrays.reset_arrays(seed=1)
        with pytest.raises(ValueError, match=r"actions must be 0 \(STOP\) or 1 \(GO\): robot_3"):
            arrays.step_arrays(np.array([1, 1, 1, 2, 1, 1, 1, 1]))


def test_pettingzoos_suites_pass_with_the_bodies_in_two_regions():
    kwargs = {"layout": FLOOR, "num_robots": 4, "ticks_per_move": 3, "delays": DELAYS,
              "max_cycles": 40, "physics": True, "moves": "rotate",
              "physics_threads": 2}  # fmt: skip
    quietly(parallel_api_test, async_fleet.parallel_env(**kwargs), num_cycles=60)
    quietly(parallel_seed_test, functools.partial(async_fleet.parallel_env, **kwargs), 30)
    quietly(api_test, async_fleet.env(**kwargs), num_cycles=30)


@pytest.mark.parametrize("moves", ["grid", "rotate"])
def test_ten_thousand_bodies_run_on_ticks_on_two_threads_and_keep_apart(moves):
    delays = DelayConfig(seed=0, min_delay=1, max_delay=20, event_model="bernoulli",
                         p_delay=0.005, duration_model="uniform")  # fmt: skip
    env = async_fleet.parallel_env(grid_rows=150, grid_cols=150, num_robots=10_000,
                                   physics=True, ticks_per_move=3, delays=delays, moves=moves,
                                   physics_threads=2, max_cycles=6)  # fmt: skip
    env.reset_arrays(seed=0)
    go = np.ones(env.num_robots, dtype=np.int64)
    while env.agents:
        step = env.step_arrays(go)
    record = env.safety
    assert record.steps == 6 * env.tick_steps
    assert record.body_contacts == record.wall_contacts == record.split_contacts == 0
    assert record.closest_approach >= record.bound
    assert env.execution.measures.delayed > 0  # the delays did hold robots
    assert (step.infos["closest_approach"] >= record.bound).all()


def test_the_physics_twin_takes_as_many_robots_as_the_machines_memory_holds(monkeypatch):
    from warehouse_phys.physics import config

    monkeypatch.setattr(config, "machine_memory", lambda: 160 * 2**20)  # 160 MiB: 10,240
    message = (
        r"^num_robots: 12,000 robots' bodies need about 187\.5 MiB \(16 KiB a robot\), "
        r"more than this machine's 160\.0 MiB: the physics world holds at most 10,240$"
    )
    with pytest.raises(ValueError, match=message):
        async_fleet.parallel_env(grid_rows=160, grid_cols=160, num_robots=12_000, physics=True)
    async_fleet.parallel_env(grid_rows=160, grid_cols=160, num_robots=12_000)  # the grid twin
    async_fleet.parallel_env(grid_rows=4, grid_cols=4, num_robots=2, physics=True)
