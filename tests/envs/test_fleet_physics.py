"""The physics fleet is safe for every setting it accepts: the bodies end on the grid
twin's cells and no two discs come closer than their diameter less the collision slop,
in the tightest situations the traffic rule grants, in crowds, and at warehouse scale."""

import functools
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st

with warnings.catch_warnings():
    # pettingzoo.test imports one of PettingZoo's own games through a path it deprecates.
    warnings.simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from tests.envs.test_fleet import pettingzoo_quietly
from tests.memory import CAN_MEASURE, growth_per_reset
from warehouse_phys.envs import fleet
from warehouse_phys.envs.fleet import setup as fleet_setup
from warehouse_phys.physics import (
    COLLISION_SLOP,
    PENETRATION_TOLERANCE,
    SNAP_ERROR_BOUND,
    SUPPORTED_RANGES,
    PhysicsConfig,
    check_controller,
)
from warehouse_phys.rl.fleet_planners import pibt_policy
from warehouse_phys.world.layouts import make_grid, suggested_time_limit
from warehouse_phys.world.traffic import CLEARANCE_MARGIN, WAIT, check_clearance

LEFT, DOWN, RIGHT, UP = range(4)
DEFAULTS = PhysicsConfig()

#: (name, layout whose S cells are the robots' starts in reading order, joint actions)
TIGHT = [
    ("following at one cell", ["SS..", "...."], [RIGHT, RIGHT]),
    ("following round a corner", ["SS", ".."], [RIGHT, DOWN]),
    ("waiting beside one that passes", ["S..", ".S."], [RIGHT, WAIT]),
    ("head-on into neighbouring cells", ["S..S", "...."], [RIGHT, LEFT]),
    ("converging: one goes, two wait", ["S.S", ".S.", "..."], [RIGHT, LEFT, UP]),
    ("entering beside one that bumps back", ["S.S#", "...."], [RIGHT, RIGHT]),
    ("bumping back to back", ["S.", "S."], [UP, DOWN]),
    ("a bump beside one that passes", ["S..", "S.."], [LEFT, RIGHT]),
    ("a row of four converging and following", ["SS.SS", "....."], [RIGHT, RIGHT, LEFT, LEFT]),
]  # fmt: skip


def all_pairs_gap(env: fleet.WarehouseFleetEnv) -> float:
    """The smallest gap between any two discs at any physics step of the last step,
    every pair compared (independent of the fleet's own diagnostic)."""
    paths = env.world.last_paths  # (N, steps, 2) [cells]
    apart = np.linalg.norm(paths[:, None] - paths[None, :], axis=-1).min(axis=-1)
    np.fill_diagonal(apart, np.inf)
    return float(apart.min()) - env.physics.robot_diameter


@functools.cache
def default_time_limit(layout: tuple[str, ...]) -> int:
    """The fleet's default ``max_cycles`` on ``layout``, computed once rather than at
    every one of the hypothesis test's builds."""
    return suggested_time_limit(make_grid(None, None, layout))


def twins(values: dict, **kwargs: object) -> tuple:
    return fleet.parallel_env(**kwargs, **values), fleet.parallel_env(
        physics=True, **kwargs, **values
    )


def assert_twins_agree(grid, phys, actions: dict) -> float:
    """Step both twins; assert the same cells and grants; return the closest gap."""
    _, g_rewards, _, _, g_infos = grid.step(actions)
    _, p_rewards, _, _, p_infos = phys.step(actions)
    assert np.array_equal(grid.robot_cells, phys.robot_cells)
    assert g_rewards == p_rewards
    for agent, info in p_infos.items():
        assert info["refused"] == g_infos[agent]["refused"]
        assert info["snap_error"] < SNAP_ERROR_BOUND
        assert info["min_gap"] > -COLLISION_SLOP
    gap = all_pairs_gap(phys)
    assert gap > -COLLISION_SLOP
    return gap


@st.composite
def accepted_settings(draw) -> dict:
    """Physical keywords spread log-uniformly across their supported ranges (wide) or
    close to the defaults, with a whole number of steps a move; kept only if the physics
    fleet accepts them."""
    spread = draw(st.sampled_from([0.3, 1.0, 3.0]))

    def around(name: str, spread: float) -> float:
        low, high = SUPPORTED_RANGES[name]
        value = getattr(DEFAULTS, name) * 10 ** draw(st.floats(-spread, spread))
        return float(min(max(value, low), high))

    names = ("cell_size", "robot_mass", "floor_damping", "max_speed", "max_force", "gain")
    values = {name: around(name, spread) for name in names}
    values["robot_radius"] = values["cell_size"] * draw(st.floats(0.01, 0.499))
    dt = around("dt", spread / 2)
    steps = draw(st.integers(2, 60))
    settle = draw(st.integers(1, steps - 1))
    values.update(dt=dt, move_duration=dt * steps, settle_time=dt * settle)
    try:  # max_cycles given: the floor's default time limit takes longer than the check
        fleet.parallel_env(num_robots=1, physics=True, max_cycles=1, **values)
    except (ValueError, TypeError):
        reject()
    return values


@pytest.mark.slow
@settings(max_examples=30, suppress_health_check=[HealthCheck.filter_too_much,
                                                   HealthCheck.too_slow])  # fmt: skip
@given(values=accepted_settings(), seed=st.integers(0, 2**16), n_robots=st.integers(2, 8))
def test_every_accepted_setting_keeps_the_fleet_apart_and_on_the_grid_twins_cells(
    values, seed, n_robots
):
    """Every tight situation the rule grants, then a crowd of 2 to 8 robots moving at
    random on a 5 x 5 floor: the same cells as the grid twin at every step, and no two
    discs closer than their diameter less the collision slop at any physics step."""
    for _, layout, joint in TIGHT:
        grid, phys = twins(values, num_robots=len(joint), layout=layout,
                           max_cycles=default_time_limit(tuple(layout)))  # fmt: skip
        grid.reset(seed=seed)
        phys.reset(seed=seed)
        agents = phys.possible_agents
        assert_twins_agree(grid, phys, dict(zip(agents, joint, strict=True)))
        back = [WAIT if a == WAIT else (a + 2) % 4 for a in joint]  # and back (if not parked)
        if phys.agents:
            assert_twins_agree(grid, phys, {a: b for a, b in zip(agents, back, strict=True)
                                            if a in phys.agents})  # fmt: skip
    grid, phys = twins(values, num_robots=n_robots, grid_rows=5, grid_cols=5, lifelong=True,
                       starts="random", max_cycles=25)  # fmt: skip
    grid.reset(seed=seed)
    phys.reset(seed=seed)
    rng = np.random.default_rng(seed)
    while phys.agents:
        actions = rng.choice(5, size=n_robots, p=[0.22, 0.22, 0.22, 0.22, 0.12]).tolist()
        assert_twins_agree(grid, phys, dict(zip(phys.agents, actions, strict=True)))


@pytest.mark.parametrize(("name", "layout", "joint"), TIGHT, ids=[t[0] for t in TIGHT])
def test_the_default_robots_keep_their_clearance_in_every_tight_situation(name, layout, joint):
    grid, phys = twins({}, num_robots=len(joint), layout=layout)
    grid.reset(seed=0)
    phys.reset(seed=0)
    gap = assert_twins_agree(grid, phys, dict(zip(phys.possible_agents, joint, strict=True)))
    # The default controller does not overshoot: the tightest is the corner, sqrt(0.5) apart.
    assert gap >= np.sqrt(0.5) - 0.6 - 1e-6, name


#: A fast, lightly damped controller: a free move runs about 0.15 cells past its cell.
OVERSHOOTING = {"max_speed": 7.0, "gain": 100.0, "max_force": 2000.0, "move_duration": 0.5,
                "settle_time": 0.15}  # fmt: skip


def test_a_controller_that_overshoots_too_far_for_its_robots_is_refused_by_name():
    motion = check_controller(PhysicsConfig(**OVERSHOOTING))
    assert motion.overshoot > 0.1
    largest = 1 - 2 * motion.overshoot - CLEARANCE_MARGIN  # the largest diameter allowed
    fleet.parallel_env(physics=True, robot_radius=0.49 * largest, **OVERSHOOTING)
    with pytest.raises(ValueError, match=r"head-on come within 1 - 2 x 0\.146 = 0\.708 cells"):
        fleet.parallel_env(physics=True, robot_radius=0.51 * largest, **OVERSHOOTING)
    # The grid twin and a single robot have no body to touch: they accept the setting.
    fleet.parallel_env(robot_radius=0.51 * largest, **OVERSHOOTING)
    assert check_controller(PhysicsConfig(robot_radius=0.51 * largest, **OVERSHOOTING))


def test_the_robots_the_bound_refuses_would_touch_head_on(monkeypatch):
    """Why the bound is there: forced past the check, the robots it refuses collide."""
    motion = check_controller(PhysicsConfig(**OVERSHOOTING))
    radius = 0.5 * (1 - 2 * motion.overshoot + 0.03)  # wider than the head-on approach
    with pytest.raises(ValueError, match="too large for this controller"):
        check_clearance(2 * radius, *motion)
    monkeypatch.setattr(fleet_setup, "check_clearance", lambda *args: None)
    phys = fleet.parallel_env(num_robots=2, physics=True, layout=["S..S", "...."],
                              robot_radius=radius, **OVERSHOOTING)  # fmt: skip
    phys.reset(seed=0)
    phys.step({"robot_0": RIGHT, "robot_1": LEFT})
    assert all_pairs_gap(phys) < -COLLISION_SLOP


# ------------------------------------------------------------- restarts, memory
@pytest.mark.skipif(not CAN_MEASURE, reason="resident memory is read from Linux's /proc")
def test_a_reset_restarts_the_world_and_holds_no_more_memory():
    env = fleet.parallel_env(num_robots=8, physics=True, grid_rows=6, grid_cols=6,
                             lifelong=True)  # fmt: skip
    env.reset(seed=0)
    world = env.world
    env.step(dict.fromkeys(env.agents, RIGHT))
    env.reset(seed=1)
    assert env.world is world  # restarted, not rebuilt
    # Each rebuilt world used to keep a few kilobytes of chipmunk's arrays for good.
    assert growth_per_reset(lambda seed: env.reset(seed=seed), 2000) < 100


def test_without_gap_tracking_the_fleet_moves_alike_and_reads_no_paths():
    kwargs = {"num_robots": 6, "physics": True, "grid_rows": 5, "grid_cols": 5, "lifelong": True,
              "safety": False}  # the safety measures read the paths too  # fmt: skip
    tracked, plain = fleet.parallel_env(**kwargs), fleet.parallel_env(track_gaps=False, **kwargs)
    tracked.reset(seed=3)
    plain.reset(seed=3)
    assert not plain.world.record_path
    rng = np.random.default_rng(3)
    for _ in range(30):
        actions = dict(zip(tracked.agents, rng.integers(5, size=6).tolist(), strict=True))
        _, _, _, _, with_gaps = tracked.step(actions)
        _, _, _, _, infos = plain.step(actions)
        assert np.array_equal(tracked.robot_cells, plain.robot_cells)
        for agent, info in infos.items():
            assert "min_gap" not in info
            assert info == {k: v for k, v in with_gaps[agent].items() if k != "min_gap"}
    with pytest.raises(ValueError, match="does not record the motion: make it with render_mode"):
        plain.move_frames()
    with pytest.raises(TypeError, match="track_gaps must be a bool"):
        fleet.parallel_env(track_gaps=1)
    with pytest.raises(AttributeError):  # fixed when built: the world reads as it was made
        plain.track_gaps = True
    # Frames of the motion still come when asked for.
    framed = fleet.parallel_env(track_gaps=False, render_mode="rgb_array", **kwargs)
    framed.reset(seed=3)
    framed.step(dict.fromkeys(framed.agents, WAIT))
    assert len(framed.move_frames()) == framed.physics.steps_per_move


# ------------------------------------------------------------------ at scale
def test_256_robots_on_the_kiva_warehouse_follow_the_planner_as_the_grid_twin_does():
    """The proof at warehouse scale: 256 robots, the planner, 256 lifelong steps."""
    kwargs = {"num_robots": 256, "layout": "warehouse", "lifelong": True, "max_cycles": 256}
    grid, phys = twins({}, **kwargs)
    grid_plan, phys_plan = pibt_policy(0), pibt_policy(0)
    g_obs, g_infos = grid.reset(seed=0)
    p_obs, p_infos = phys.reset(seed=0)
    closest, steps = np.inf, 0
    while phys.agents:
        actions = grid_plan(grid, g_obs, g_infos)
        assert phys_plan(phys, p_obs, p_infos) == actions
        g_obs, g_rewards, _, _, g_infos = grid.step(actions)
        p_obs, p_rewards, _, _, p_infos = phys.step(actions)
        assert np.array_equal(grid.robot_cells, phys.robot_cells)
        assert g_rewards == p_rewards
        assert not any(info["refused"] for info in p_infos.values())
        assert max(info["snap_error"] for info in p_infos.values()) < SNAP_ERROR_BOUND
        closest = min(closest, *(info["min_gap"] for info in p_infos.values()))
        steps += 1
    assert steps == 256
    assert np.array_equal(grid.deliveries, phys.deliveries)
    assert phys.deliveries.sum() / steps > 4  # deliveries per step: the grid's throughput
    # The closest the rule lets two default robots come: a corner follow, sqrt(0.5) - 0.6.
    assert closest == pytest.approx(np.sqrt(0.5) - 0.6, abs=0.01)


@pytest.mark.parametrize("moves", ["grid", "rotate"])
def test_ten_thousand_bodies_move_in_lock_step_on_two_threads_and_keep_apart(moves):
    env = fleet.parallel_env(num_robots=10_000, physics=True, grid_rows=150, grid_cols=150,
                             starts="random", lifelong=True, moves=moves,
                             physics_threads=2)  # fmt: skip
    env.reset_arrays(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(2):  # random actions: crowds, refusals and bumps into the floor's edge
        step = env.step_arrays(rng.integers(env.action_space("robot_0").n, size=10_000))
    record = env.safety
    assert record.steps == 2 * env.world.config.steps_per_move
    assert record.body_contacts == record.split_contacts == 0
    assert record.closest_approach >= record.bound
    assert record.deepest_wall <= PENETRATION_TOLERANCE
    assert (step.infos["closest_approach"] >= record.bound).all()


@pytest.mark.parametrize(("n_robots", "cycles"), [(2, 100), (64, 60), (256, 24)])
def test_pettingzoos_suites_pass_for_physics_fleets_of_any_size(n_robots, cycles):
    side = 4 if n_robots == 2 else 24
    kwargs = {"num_robots": n_robots, "physics": True, "grid_rows": side, "grid_cols": side,
              "starts": "random", "max_cycles": 2 * cycles}  # fmt: skip
    pettingzoo_quietly(parallel_api_test, fleet.parallel_env(**kwargs), num_cycles=cycles)
    pettingzoo_quietly(parallel_seed_test, functools.partial(fleet.parallel_env, **kwargs), cycles)
    pettingzoo_quietly(api_test, fleet.env(**kwargs), num_cycles=cycles // 2)


@pytest.mark.slow
@pytest.mark.skipif(not CAN_MEASURE, reason="resident memory is read from Linux's /proc")
def test_a_physics_fleet_of_1024_robots_takes_little_memory(run_python):
    script = """
import numpy as np
from tests.memory import resident_bytes
from warehouse_phys.envs import fleet
before = resident_bytes()
env = fleet.parallel_env(num_robots=1024, physics=True, grid_rows=48, grid_cols=48,
                         starts="random", lifelong=True)
env.reset(seed=0)
rng = np.random.default_rng(0)
peak = 0
for _ in range(20):
    env.step(dict(zip(env.agents, rng.integers(5, size=1024).tolist())))
    peak = max(peak, resident_bytes())
print((peak - before) / 2**20)
"""
    assert float(run_python(script)) < 200  # [MiB]; all pairs of robots took 787 MiB
