"""Turning robots in the fleet (``moves="rotate"``): the grid twin follows the rule, the
physics twin equals it step by step without contact for every accepted setting, and
the frames show the headings."""

import functools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st

from tests.envs.test_fleet import pettingzoo_quietly
from tests.envs.test_fleet_physics import (
    TIGHT,
    accepted_settings,
    all_pairs_gap,
    default_time_limit,
)
from warehouse_phys.drawing.colours import HEADING_POINTER
from warehouse_phys.drawing.map_frames import fleet_map_frame
from warehouse_phys.envs import fleet
from warehouse_phys.physics import (
    COLLISION_SLOP,
    HEADING_SNAP_BOUND,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
    check_controller,
)
from warehouse_phys.rl.fleet_planners import pibt_policy
from warehouse_phys.world.headings import HEADING_MOVES, MOVE_HEADINGS, TurnAction, turning_moves
from warehouse_phys.world.traffic import WAIT

with __import__("warnings").catch_warnings():
    __import__("warnings").simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test

FORWARD, CLOCKWISE, COUNTER, STAY = range(4)
MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def turning_twins(values: dict, **kwargs: object) -> tuple:
    kwargs = {"moves": "rotate", **kwargs, **values}
    return fleet.parallel_env(**kwargs), fleet.parallel_env(physics=True, **kwargs)


def step_twins(grid, phys, actions: dict) -> float:
    """Step both twins; assert the same cells, headings and grants, the snap bounds and
    no contact; return the closest gap."""
    _, g_rewards, _, _, g_infos = grid.step(actions)
    _, p_rewards, _, _, p_infos = phys.step(actions)
    assert np.array_equal(grid.robot_cells, phys.robot_cells)
    assert np.array_equal(grid.robot_headings, phys.robot_headings)
    assert g_rewards == p_rewards
    assert phys.world.heading_errors.max() < HEADING_SNAP_BOUND
    for agent, info in p_infos.items():
        assert info["refused"] == g_infos[agent]["refused"]
        assert info["snap_error"] < SNAP_ERROR_BOUND
    gap = all_pairs_gap(phys)
    assert gap > -COLLISION_SLOP
    return gap


def test_the_grid_twin_applies_the_turning_rule():
    env = fleet.parallel_env(num_robots=6, moves="rotate", grid_rows=4, grid_cols=5,
                             lifelong=True, starts="random")  # fmt: skip
    env.reset(seed=0)
    assert env.robot_headings.tolist() == [0] * 6  # every robot faces east at the start
    assert env.action_space("robot_0").n == 4
    rng = np.random.default_rng(0)
    cols = env.grid.cols
    for _ in range(50):
        here, headings = env.robot_cells @ [cols, 1], env.robot_headings.copy()
        actions = rng.integers(4, size=6)
        grants = turning_moves(env.grid, here, headings, actions, None)
        _, _, _, _, infos = env.step(dict(zip(env.agents, actions.tolist(), strict=True)))
        assert (env.robot_cells @ [cols, 1]).tolist() == grants.ends.tolist()
        assert env.robot_headings.tolist() == grants.headings.tolist()
        assert [infos[a]["refused"] for a in env.agents] == grants.refused.tolist()
    with pytest.raises(ValueError, match=r"robot_0's action must be 0..3 \(3 is WAIT\), got 4"):
        env.step(dict.fromkeys(env.agents, 4))


def test_observations_carry_the_heading_in_every_kind():
    kwargs = {"num_robots": 2, "moves": "rotate", "grid_rows": 3, "grid_cols": 4}
    local = fleet.parallel_env(**kwargs)
    obs, _ = local.reset(seed=1)
    assert local.observation_space("robot_0").nvec.tolist() == [3, 4, 3, 4, 4]
    obs, *_ = local.step({"robot_0": CLOCKWISE, "robot_1": STAY})
    assert obs["robot_0"][4] == 1
    assert obs["robot_1"][4] == 0
    assert local.state().reshape(2, 5)[:, 4].tolist() == [1, 0]
    neighbours = fleet.parallel_env(observation="neighbours", **kwargs)
    neighbours.reset(seed=1)
    assert neighbours.observation_space("robot_0").nvec.tolist() == [3, 4, 3, 4, 4, 16]
    onehot = fleet.parallel_env(observation="neighbours_onehot", **kwargs)
    obs, _ = onehot.reset(seed=1)
    assert obs["robot_0"].shape == (3 + 4 + 3 + 4 + 4 + 4,)
    assert obs["robot_0"][14:18].tolist() == [1, 0, 0, 0]  # facing east
    global_ = fleet.parallel_env(observation="global", **kwargs)
    assert global_.observation_space("robot_0").nvec.tolist() == [3, 4, 3, 4, 4] * 2


@pytest.mark.parametrize("physics", [False, True])
def test_pettingzoos_suites_pass_for_turning_fleets(physics):
    kwargs = {"num_robots": 3, "moves": "rotate", "max_cycles": 40, "physics": physics}
    pettingzoo_quietly(parallel_api_test, fleet.parallel_env(**kwargs), num_cycles=60)
    pettingzoo_quietly(parallel_seed_test, functools.partial(fleet.parallel_env, **kwargs), 40)
    pettingzoo_quietly(api_test, fleet.env(**kwargs), num_cycles=40)
    pettingzoo_quietly(seed_test, functools.partial(fleet.env, **kwargs), 20)


#: Tight situations of turning robots: (layout of starts, headings, joint actions).
TURNING_TIGHT = [
    (layout, [int(MOVE_HEADINGS[a]) if a != WAIT else 0 for a in joint],
     [FORWARD if a != WAIT else STAY for a in joint])
    for _, layout, joint in TIGHT
] + [
    (["S.S", "..."], [0, 2], [CLOCKWISE, COUNTER]),  # turning beside each other
    (["SS.", "..."], [0, 0], [CLOCKWISE, FORWARD]),  # following one that turns: waits
    (["S.", "S."], [3, 1], [FORWARD, FORWARD]),  # bumping back to back
]  # fmt: skip


def turned_start(env, headings):
    """Turn the robots to ``headings`` first (every robot turns clockwise as needed)."""
    for _ in range(3):
        turn = [CLOCKWISE if h != env.robot_headings[i] else STAY for i, h in enumerate(headings)]
        yield dict(zip(env.agents, turn, strict=True))


@pytest.mark.slow
@settings(max_examples=20, suppress_health_check=[HealthCheck.filter_too_much,
                                                   HealthCheck.too_slow])  # fmt: skip
@given(values=accepted_settings(), seed=st.integers(0, 2**16), n_robots=st.integers(2, 8))
def test_every_accepted_setting_turns_the_bodies_as_the_grid_twin_and_keeps_them_apart(
    values, seed, n_robots
):
    """The tight situations, then a crowd of 2 to 8 turning robots acting at random: the
    same cells and headings as the grid twin, angles within the heading bound, and no two
    discs closer than their diameter less the collision slop."""
    try:  # max_cycles given: the floor's default time limit takes longer than the check
        fleet.parallel_env(num_robots=1, physics=True, moves="rotate", max_cycles=1, **values)
    except ValueError:
        reject()
    for layout, headings, joint in TURNING_TIGHT:
        grid, phys = turning_twins(values, num_robots=len(joint), layout=layout,
                                   max_cycles=default_time_limit(tuple(layout)))  # fmt: skip
        grid.reset(seed=seed)
        phys.reset(seed=seed)
        for actions in turned_start(phys, headings):
            step_twins(grid, phys, actions)
        if phys.agents:
            step_twins(grid, phys, dict(zip(phys.agents, joint, strict=True)))
    grid, phys = turning_twins(values, num_robots=n_robots, grid_rows=5, grid_cols=5,
                               lifelong=True, starts="random", max_cycles=25)  # fmt: skip
    grid.reset(seed=seed)
    phys.reset(seed=seed)
    rng = np.random.default_rng(seed)
    while phys.agents:
        actions = rng.choice(4, size=n_robots, p=[0.4, 0.2, 0.2, 0.2]).tolist()
        step_twins(grid, phys, dict(zip(phys.agents, actions, strict=True)))


def test_the_controller_check_tries_turns_and_finds_the_default_turns_exact():
    motion = check_controller(PhysicsConfig(), turning=True)
    assert motion == check_controller(PhysicsConfig())  # turning adds no overshoot or drift
    # A controller too weak to turn a quarter in a move is refused with advice.
    with pytest.raises(ValueError, match="raise max_force, max_speed or gain"):
        check_controller(PhysicsConfig(max_force=40.0, robot_mass=24.0), turning=True)


def test_256_planned_turning_robots_on_warehouse_large_match_the_grid_twin_without_contact():
    if not MAPS.is_dir():
        pytest.skip(f"benchmark maps not found at {MAPS} (the shared folder beside the checkout)")
    kwargs = {"num_robots": 256, "layout": str(MAPS / "warehouse-large-140-500.map"),
              "lifelong": True, "max_cycles": 128}  # fmt: skip
    grid, phys = turning_twins({}, **kwargs)
    grid_plan, phys_plan = pibt_policy(0), pibt_policy(0)
    g_obs, g_infos = grid.reset(seed=0)
    p_obs, p_infos = phys.reset(seed=0)
    closest, turns, steps = np.inf, 0, 0
    while phys.agents:
        actions = grid_plan(grid, g_obs, g_infos)
        assert phys_plan(phys, p_obs, p_infos) == actions
        turns += sum(a in (CLOCKWISE, COUNTER) for a in actions.values())
        g_obs, g_rewards, _, _, g_infos = grid.step(actions)
        p_obs, p_rewards, _, _, p_infos = phys.step(actions)
        assert np.array_equal(grid.robot_cells, phys.robot_cells)
        assert np.array_equal(grid.robot_headings, phys.robot_headings)
        assert g_rewards == p_rewards
        assert not any(info["refused"] for info in p_infos.values())
        closest = min(closest, *(info["min_gap"] for info in p_infos.values()))
        steps += 1
    assert steps == 128
    assert turns > 500
    assert phys.deliveries.sum() > 0
    # No contact: the closest two default robots come is a corner follow, sqrt(0.5) - 0.6.
    assert closest == pytest.approx(np.sqrt(0.5) - 0.6, abs=0.01)


def test_every_frame_kind_shows_the_heading():
    env = fleet.parallel_env(num_robots=2, moves="rotate", layout=["S.S.", "...."],
                             render_mode="ansi")  # fmt: skip
    env.reset(seed=0)
    env.step({"robot_0": CLOCKWISE, "robot_1": COUNTER})
    assert env.render().splitlines()[0] == "0v_ 1^_"
    for physics in (False, True):
        pictures = fleet.parallel_env(
            num_robots=2,
            moves="rotate",
            layout=["S.S.", "...."],
            render_mode="rgb_array",
            physics=physics,
            cell_px=32,
        )
        pictures.reset(seed=0)
        before = pictures.render()
        pictures.step({"robot_0": CLOCKWISE, "robot_1": STAY})
        after = pictures.render()
        pointer = np.all(after == HEADING_POINTER, axis=-1)
        assert pointer[16:32, 8:24].any()
        assert not pointer[0:14, 8:24].any()
        assert not np.array_equal(before[:32, :32], after[:32, :32])
        assert np.array_equal(before[:32, 64:96], after[:32, 64:96])  # robot 1 did not turn
    frames = pictures.move_frames()  # the physics robot turning, frame by frame
    assert len(frames) == pictures.physics.steps_per_move
    assert not np.array_equal(frames[2][:32, :32], frames[-1][:32, :32])
    frame = fleet_map_frame(env.grid, env.robot_cells, env.package_cells, cell_px=8,
                            headings=env.robot_headings)  # fmt: skip
    marks = np.all(frame == HEADING_POINTER, axis=-1)
    assert marks[4:8, 0:8].any()
    assert not marks[0:3, 0:8].any()
    assert marks[0:4, 16:24].any()
    assert not marks[5:8, 16:24].any()


def test_a_turning_robot_in_the_grid_twin_is_refused_into_a_wall_and_turns_in_place():
    env = fleet.parallel_env(num_robots=1, moves="rotate", grid_rows=2, grid_cols=2)
    env.reset(seed=0)
    env.step({"robot_0": FORWARD})
    env.step({"robot_0": FORWARD})  # into the east wall: stays
    assert env.robot_cells.tolist() == [[0, 1]]
    env.step({"robot_0": CLOCKWISE})
    env.step({"robot_0": FORWARD})
    assert env.robot_cells.tolist() == [[1, 1]]
    assert env.robot_headings.tolist() == [1]
    assert int(HEADING_MOVES[1]) == 1
    assert TurnAction.WAIT == STAY
