"""Guided PIBT: traffic grants every plan, the guidance's bookkeeping holds, it is
deterministic and bounded, and it steers robots apart where plain PIBT meets head-on."""

import hashlib
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tests.conftest import ROOT
from tests.world.random_floors import shelf_layout
from warehouse_phys.envs import fleet
from warehouse_phys.planners import traffic_flow
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.guidance_config import GuidanceConfig
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.traffic_guidance import TrafficGuidance
from warehouse_phys.rl.fleet_planners import guided_pibt_policy, planner_policy
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import resolve_turning_moves
from warehouse_phys.world.traffic import moves_refused_by_floor, resolve_moves

#: Two aisles joined at both ends: a robot each way has a lane of its own.
TWO_AISLES = ["........", ".######.", "........"]


def play(env, policy, seed, steps):
    """Play ``policy``; the moves traffic refused and a digest of every action taken."""
    observations, infos = env.reset(seed=seed)
    refused, digest = 0, hashlib.sha256()
    for _ in range(steps):
        if not env.agents:
            break
        actions = policy(env, observations, infos)
        digest.update(json.dumps(sorted(actions.items())).encode())
        observations, _, _, _, infos = env.step(actions)
        observations = {agent: observations[agent] for agent in env.agents}
        refused += sum(info["refused"] for info in infos.values())
    return refused, digest.hexdigest()


def flow_of_paths(guidance: TrafficGuidance) -> np.ndarray:
    """The flow recounted from the stored guide paths, each from its robot's cursor on."""
    flow = np.zeros_like(guidance.flow)
    paths = guidance._paths
    for i in np.flatnonzero(paths.moves >= 0).tolist():
        first = paths.start[i] + paths.cursor[i]
        rest = paths.pool[first : paths.start[i] + paths.moves[i] + 1]
        traffic_flow.add_flow(guidance._graph, flow, rest, 1)
    return flow


@settings(max_examples=40)
@given(
    rows=st.integers(2, 7),
    cols=st.integers(2, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 12),
    seed=st.integers(0, 2**16),
    corner_follows=st.booleans(),
    lifelong=st.booleans(),
    moves=st.sampled_from(["grid", "rotate"]),
    name=st.sampled_from(["guided", "guided-costs", "guided-paths"]),
)
def test_traffic_grants_every_guided_plan_on_any_floor(
    rows, cols, shelf_bits, robots, seed, corner_follows, lifelong, moves, name
):
    layout = shelf_layout(rows, cols, shelf_bits)
    try:
        env = fleet.parallel_env(
            num_robots=robots, layout=layout, starts="random",
            on_delivery="new_package" if lifelong else "park", max_cycles=30, moves=moves,
            **({} if corner_follows else {"robot_radius": 0.34}),
        )  # fmt: skip
    except ValueError:  # too small for the fleet
        return
    refused, _ = play(env, planner_policy(name, seed, refresh=2), seed, 30)
    assert refused == 0


@settings(max_examples=30)
@given(
    rows=st.integers(3, 8),
    cols=st.integers(3, 8),
    shelf_bits=st.integers(0, 2**64 - 1),
    data=st.data(),
)
def test_plans_are_granted_and_the_flow_is_what_the_paths_have_left(rows, cols, shelf_bits, data):
    """Any robots and goals, robots moved as traffic grants (pushes, rejoins, reroutes
    that keep a path's tail, new goals, pool compaction): every plan is granted, the flow
    always equals the moves left on the stored guide paths, and no path holds a cell
    twice."""
    layout = [["#" if (shelf_bits >> (r * 8 + c)) & 1 and (r + c) % 2 else "."
               for c in range(cols)] for r in range(rows)]  # fmt: skip
    try:
        grid = WarehouseGrid.from_layout(["".join(row) for row in layout])
    except ValueError:
        assume(False)
    free = [(r, c) for r in range(rows) for c in range(cols) if layout[r][c] == "."]
    cells = np.array(data.draw(st.lists(st.sampled_from(free), min_size=1, unique=True)))
    n = len(cells)
    rejoin, reroute = data.draw(st.booleans()), data.draw(st.integers(0, 3))
    config = GuidanceConfig(refresh=1, window=3, rejoin=rejoin, reroute=reroute)
    planner = GuidedPIBT(grid, seed=data.draw(st.integers(0, 99)), config=config)
    for step in range(8):
        if step % 3 == 0:
            goals = np.array(data.draw(st.lists(st.sampled_from(free), min_size=n, max_size=n)))
        actions = planner.plan(cells, goals)
        assert not moves_refused_by_floor(grid, cells, actions).any()
        cells, refused = resolve_moves(grid, cells, actions)
        assert not refused.any()
        guidance = planner.guidance
        assert (guidance.flow >= 0).all()
        np.testing.assert_array_equal(guidance.flow, flow_of_paths(guidance))
        paths = guidance._paths
        for i in np.flatnonzero(paths.moves >= 0).tolist():
            path = paths.pool[paths.start[i] : paths.start[i] + paths.moves[i] + 1]
            assert len(np.unique(path)) == len(path)
        if step == 4:
            guidance._paths.compact(0)
            np.testing.assert_array_equal(guidance.flow, flow_of_paths(guidance))


@pytest.mark.parametrize(
    ("name", "reroute"), [("guided-ops-repair", 0), ("guided-repair", 0), ("guided-ops-repair", 4)]
)
def test_a_turning_fleets_flow_is_its_lanes_and_what_its_paths_have_left(name, reroute):
    """A lifelong turning fleet with the repair (over operations or one step at a time),
    its one-way lanes laid, robots pushed off their paths, new goals at every delivery,
    and the one over operations handed over to unrepaired one-step plans at step 40 and
    back at step 80 (for the other, both change nothing): the flow
    stays the lanes' phantom paths plus the moves left on the stored guide paths, step
    after step (a path dropped without its flow would leave phantom traffic that grows
    over a long run), robots pushed off long paths keeping their tails too."""
    env = fleet.parallel_env(num_robots=60, layout="kiva-33-46", starts="random",
                             moves="rotate", on_delivery="new_package", max_cycles=120)  # fmt: skip
    policy = planner_policy(name, 3, reroute=reroute)
    observations, infos = env.reset(seed=3)
    for step in range(120):
        if step == 40:
            policy.planner.hand_over()
        if step == 80:
            policy.planner.hand_back()
        observations, _, _, _, infos = env.step(policy(env, observations, infos))
        guidance = policy.planner.guidance
        lanes = np.zeros_like(guidance.flow)
        np.add.at(lanes, (guidance._lane_columns, guidance._lane_moves),
                  guidance.config.turn_lane_paths)  # fmt: skip
        np.testing.assert_array_equal(guidance.flow, lanes + flow_of_paths(guidance))
    assert lanes.any()  # the floor has one-cell corridors, so lanes were laid


def test_without_any_guidance_the_plan_is_plain_pibts():
    """No search allowed (a zero time limit, or none allowed): every robot is valued by
    PIBT's distances, and the plans are plain PIBT's for the same seed, bit for bit."""
    env = fleet.parallel_env(num_robots=120, layout="warehouse", lifelong=True, max_cycles=40)
    plain = play(env, planner_policy("pibt", 3), 3, 40)
    for bound in ({"time_limit": 0.0}, {"max_searches": 0}):
        assert play(env, planner_policy("guided", 3, **bound), 3, 40) == plain


def test_a_tiny_time_limit_still_gives_safe_moves_and_counts_who_it_left_unguided():
    env = fleet.parallel_env(num_robots=300, layout="warehouse", lifelong=True, max_cycles=30)
    planner = GuidedPIBT(env.grid, distances=env.distances, config=GuidanceConfig(time_limit=1e-4))
    env.reset(seed=0)
    left = []
    for _ in range(30):
        actions = planner.plan(env.robot_cells, env.package_cells)
        left.append(planner.guidance.timed_out)
        _, _, _, _, infos = env.step(dict(zip(env.agents, actions.tolist(), strict=True)))
        assert sum(info["refused"] for info in infos.values()) == 0
    assert left[0] > 0  # 300 searches do not fit in 0.1 ms
    assert planner.guidance.searches < 300


def test_the_first_step_can_have_a_bound_of_its_own():
    """``first_time_limit=inf``: the first step searches every robot's first guide path,
    however small ``time_limit`` is; the later steps keep to ``time_limit``."""
    env = fleet.parallel_env(num_robots=300, layout="warehouse", lifelong=True, max_cycles=30)
    config = GuidanceConfig(time_limit=1e-4, first_time_limit=math.inf)
    planner = GuidedPIBT(env.grid, distances=env.distances, config=config)
    env.reset(seed=0)
    searches, left = [], []
    for _ in range(30):
        actions = planner.plan(env.robot_cells, env.package_cells)
        searches.append(planner.guidance.searches)
        left.append(planner.guidance.timed_out)
        _, _, _, _, infos = env.step(dict(zip(env.agents, actions.tolist(), strict=True)))
        assert sum(info["refused"] for info in infos.values()) == 0
    assert (searches[0], left[0]) == (300, 0)
    assert max(searches[1:]) < 300


def test_guided_runs_are_the_same_in_another_process():
    env = fleet.parallel_env(num_robots=96, layout="warehouse", lifelong=True, max_cycles=60)
    here = play(env, guided_pibt_policy(7), 7, 60)
    assert play(env, guided_pibt_policy(7), 7, 60) == here
    code = (
        "from tests.planners.test_guidance import play\n"
        "from warehouse_phys.envs import fleet\n"
        "from warehouse_phys.rl.fleet_planners import guided_pibt_policy\n"
        "env = fleet.parallel_env(num_robots=96, layout='warehouse', lifelong=True,"
        " max_cycles=60)\n"
        "print(play(env, guided_pibt_policy(7), 7, 60)[1])\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, check=True)  # fmt: skip
    assert done.stdout.strip() == here[1]
    assert here[0] == 0


def test_golden_plans_on_the_two_aisle_floor():
    """Four robots, two each way, over the two-aisle floor: the guided plans, recorded.
    The top aisle's robots go right and the bottom one's left, meeting nobody head-on;
    then robot_3, on its goal at the bottom left, steps up out of robot_2's way."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    cells = np.array([(0, 0), (0, 1), (2, 7), (2, 6)])
    goals = np.array([(0, 7), (2, 7), (0, 0), (2, 0)])
    planner = GuidedPIBT(grid, seed=0)
    seen = []
    for _ in range(10):
        actions = planner.plan(cells, goals)
        cells, refused = resolve_moves(grid, cells, actions)
        assert not refused.any()
        seen.append(actions.tolist())
    assert seen == GOLDEN_TWO_AISLES


def turning_plans_on_the_two_aisle_floor(config, steps):
    """Four turning robots over the two-aisle floor, two each way, facing their way: the
    plans step by step and where the robots end."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    cells = np.array([(0, 0), (0, 1), (2, 7), (2, 6)])
    goals = np.array([(0, 7), (2, 7), (0, 0), (2, 0)])
    headings = np.array([0, 0, 2, 2])  # east, east, west, west
    planner = GuidedPIBT(grid, seed=0, moves="rotate", config=config)
    seen = []
    for _ in range(steps):
        actions = planner.plan(cells, goals, headings=headings)
        cells, headings, refused = resolve_turning_moves(grid, cells, headings, actions)
        assert not refused.any()
        seen.append(actions.tolist())
    return seen, cells.tolist()


def test_golden_turning_plans_on_the_two_aisle_floor_without_lanes():
    """Without lanes each pair drives its own aisle without a turn; at the left, robot_3,
    on its goal, turns north and yields up the left column and on along the top, so that
    robot_2 reaches its goal at the top left."""
    seen, cells = turning_plans_on_the_two_aisle_floor(GuidanceConfig(turn_lane_paths=0), 11)
    assert seen == GOLDEN_TURNING_TWO_AISLES
    assert cells == [[0, 7], [2, 7], [0, 0], [0, 1]]


def test_golden_turning_plans_on_the_two_aisle_floor_keep_to_the_lanes():
    """With the lanes (the default; they run round the floor anticlockwise) no robot
    drives against one: robot_0 and robot_2 turn and go round by the left and the right
    column, robot_1 and robot_3, behind them, turn round and follow the lanes the long way,
    and robot_2 is on its goal at the top left after 11 steps, robot_0 on its at the top
    right after 14."""
    seen, cells = turning_plans_on_the_two_aisle_floor(GuidanceConfig(), 14)
    assert seen == GOLDEN_TURNING_TWO_AISLES_LANES
    assert cells == [[0, 7], [2, 1], [0, 0], [0, 2]]


#: The actions of :func:`test_golden_turning_plans_on_the_two_aisle_floor_without_lanes` (0 forward,
#: 1 clockwise, 2 counter-clockwise, 3 wait), step by step.
GOLDEN_TURNING_TWO_AISLES = [
    [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0],
    [3, 1, 3, 1], [0, 0, 0, 0], [3, 0, 1, 0], [3, 3, 0, 1], [3, 3, 0, 0],
]  # fmt: skip


#: The plans of :func:`test_golden_turning_plans_on_the_two_aisle_floor_keep_to_the_lanes`.
GOLDEN_TURNING_TWO_AISLES_LANES = [
    [1, 0, 1, 0], [0, 0, 0, 1], [0, 0, 0, 1], [2, 1, 2, 0], [0, 1, 0, 0], [0, 0, 0, 2],
    [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 2], [0, 2, 0, 0], [0, 0, 0, 0], [2, 0, 3, 0],
    [0, 2, 3, 0], [0, 0, 3, 0],
]  # fmt: skip


#: The plans of :func:`test_golden_plans_on_the_two_aisle_floor`, step by step.
GOLDEN_TWO_AISLES = [
    [2, 2, 0, 0], [2, 2, 0, 0], [2, 2, 0, 0], [2, 2, 0, 0], [2, 2, 0, 0], [2, 2, 0, 0],
    [2, 1, 0, 3], [4, 1, 3, 3], [4, 4, 3, 2], [4, 4, 1, 0],
]  # fmt: skip


def test_the_guided_planner_beats_plain_pibt_on_a_dense_warehouse():
    """256 robots on the 33 x 46 Kiva-style preset, 128 steps: guidance delivers more."""
    env = fleet.parallel_env(num_robots=256, layout="warehouse", lifelong=True, max_cycles=128)
    delivered = {}
    for name in ("pibt", "guided"):
        play(env, planner_policy(name, 0), 0, 128)
        delivered[name] = int(env.deliveries.sum())
    assert delivered["guided"] > delivered["pibt"]


def test_candidate_values_of_nan_leave_pibt_as_it_was():
    grid = WarehouseGrid.from_layout(["S.....", "..##..", "......"])
    cells = np.array([(0, 1), (2, 5), (1, 0)])
    goals = np.array([(2, 5), (0, 1), (1, 5)])
    a, b = PIBT(grid, seed=4), PIBT(grid, seed=4)
    for _ in range(5):
        plain = a.plan(cells, goals)
        valued = b.plan(cells, goals, candidate_values=np.full((3, 5), np.nan))
        np.testing.assert_array_equal(plain, valued)
        cells, _ = resolve_moves(grid, cells, plain)


@pytest.mark.parametrize("headings", [None, np.array([0, 4]), np.array([0, -1]), np.array([1])])
def test_turning_robots_without_one_heading_0_to_3_each_are_refused(headings):
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    planner = GuidedPIBT(grid, moves="rotate")
    with pytest.raises(ValueError, match="heading"):
        planner.plan(np.array([(0, 0), (2, 7)]), np.array([(0, 7), (2, 0)]), headings=headings)
