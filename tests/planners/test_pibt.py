"""The PIBT planner: traffic grants every plan, nobody is stuck, the field's throughput."""

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from tests.conftest import ROOT
from tests.world.random_floors import shelf_layout
from warehouse_phys.envs import fleet
from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.rl.fleet_evaluation import evaluate_fleet, evaluate_throughput
from warehouse_phys.rl.fleet_planners import pibt_policy
from warehouse_phys.world.grid import Action, WarehouseGrid
from warehouse_phys.world.headings import turning_moves
from warehouse_phys.world.maps import random_floor
from warehouse_phys.world.traffic import WAIT, moves_refused_by_floor, resolve_moves

#: A robot too large for corner follows (diameter 0.68 of a cell).
BIG_ROBOT = {"robot_radius": 0.34}


def run(env, policy, seed, steps):
    """Play ``policy``; returns the moves traffic refused."""
    observations, infos = env.reset(seed=seed)
    refused = 0
    for _ in range(steps):
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(policy(env, observations, infos))
        observations = {agent: observations[agent] for agent in env.agents}
        refused += sum(info["refused"] for info in infos.values())
    return refused


@given(
    rows=st.integers(2, 7),
    cols=st.integers(2, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 12),
    seed=st.integers(0, 2**16),
    corner_follows=st.booleans(),
    lifelong=st.booleans(),
    moves=st.sampled_from(["grid", "rotate"]),
)
def test_traffic_grants_every_plan_on_any_floor(
    rows, cols, shelf_bits, robots, seed, corner_follows, lifelong, moves
):
    """Four-direction and turning robots alike."""
    layout = shelf_layout(rows, cols, shelf_bits)
    try:
        env = fleet.parallel_env(
            num_robots=robots, layout=layout, starts="random",
            on_delivery="new_package" if lifelong else "park", max_cycles=40, moves=moves,
            **({} if corner_follows else BIG_ROBOT),
        )  # fmt: skip
    except ValueError:  # too small for the fleet
        return
    assert env.corner_follows == corner_follows
    assert run(env, pibt_policy(seed), seed, 40) == 0


@pytest.mark.parametrize("physical", [{}, BIG_ROBOT], ids=["corner follows", "straight only"])
def test_dense_fleets_on_the_warehouse_are_never_refused(physical):
    env = fleet.parallel_env(num_robots=400, layout="warehouse", lifelong=True, max_cycles=60,
                             **physical)  # fmt: skip
    assert run(env, pibt_policy(0), 0, 60) == 0
    assert env.deliveries.sum() > 0


def test_a_pushed_robot_goes_straight_on_without_corner_follows():
    grid = WarehouseGrid.from_layout(["S...", "....", "...."])
    cells = np.array([(1, 0), (1, 1)])
    goals = np.array([(1, 2), (0, 1)])  # robot_1 blocks robot_0, and wants to go up
    for corner_follows in (True, False):
        planner = PIBT(grid, corner_follows=corner_follows, seed=0)
        planner._priority = np.array([5.0, 0.5])  # robot_0 plans first
        planner._goals = goals[:, 0] * 4 + goals[:, 1]
        actions = planner.plan(cells, goals)
        _, refused = resolve_moves(grid, cells, actions, corner_follows=corner_follows)
        assert not refused.any()
        assert actions[0] == 2  # robot_0 goes right, pushing robot_1
        assert actions[1] == (3 if corner_follows else 2)  # up round the corner, or straight


@given(
    rows=st.integers(2, 8),
    cols=st.integers(2, 8),
    shelf_bits=st.integers(0, 2**64 - 1),
    data=st.data(),
    corner_follows=st.booleans(),
)
def test_every_plan_is_granted_whatever_the_robots_and_goals(
    rows, cols, shelf_bits, data, corner_follows
):
    """Any robots, goals (a parked robot's cell among them), parked and absent robots:
    traffic grants every move of every plan in full, no move bumps into a wall, and a
    robot that is parked or gone waits."""
    layout = [["#" if (shelf_bits >> (r * 8 + c)) & 1 and (r + c) % 2 else "."
               for c in range(cols)] for r in range(rows)]  # fmt: skip
    try:
        grid = WarehouseGrid.from_layout(["".join(row) for row in layout])
    except ValueError:  # a floor without a cell for a package
        assume(False)
    free = [(r, c) for r in range(rows) for c in range(cols) if layout[r][c] == "."]
    chosen = data.draw(st.lists(st.sampled_from(free), min_size=1, unique=True))
    n = len(chosen)
    cells = np.array(chosen)
    goals = np.array(data.draw(st.lists(st.sampled_from(free), min_size=n, max_size=n)))
    present = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    parked = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n))) & present
    planner = PIBT(grid, corner_follows=corner_follows, seed=data.draw(st.integers(0, 99)))
    for _ in range(4):
        actions = planner.plan(cells, goals, present & ~parked, present)
        assert (actions[~present | parked] == WAIT).all()
        here, act = cells[present], actions[present]
        assert not moves_refused_by_floor(grid, here, act, parked[present]).any()
        ends, refused = resolve_moves(grid, here, act, parked[present],
                                      corner_follows=corner_follows)  # fmt: skip
        assert not refused.any()
        cells = cells.copy()
        cells[present] = ends


def test_without_corner_follows_a_robot_in_the_way_leaves_and_the_cell_waits_for_the_other():
    """robot_1 stands against the wall on robot_0's goal; pushing it on is impossible,
    so it inherits robot_0's priority and steps aside (down), and robot_0 enters next."""
    grid = WarehouseGrid.from_layout(["S....", ".....", ".....", "....."])
    cells = np.array([(1, 3), (1, 4)])
    goals = np.array([(1, 4), (3, 2)])
    planner = PIBT(grid, corner_follows=False, seed=0)
    planner.plan(cells, goals)  # priorities now grow: robot_0 first (tie-breaker aside)
    planner._priority = np.array([5.0, 0.5])
    seen = []
    for _ in range(2):
        actions = planner.plan(cells, goals)
        cells, refused = resolve_moves(grid, cells, actions, corner_follows=False)
        assert not refused.any()
        seen.append(actions.tolist())
    assert seen == [[WAIT, Action.DOWN], [Action.RIGHT, Action.DOWN]]


@pytest.mark.parametrize(("layout", "robots"), [(None, 2), ("aisles", 4)])
def test_without_corner_follows_every_package_is_delivered_or_walled_off(layout, robots):
    """Robots that cannot follow each other round corners still deliver (2 robots on
    the 4 x 5 floor: 32 of 40 before lines in the way stepped aside)."""
    env = fleet.parallel_env(num_robots=robots, layout=layout, **BIG_ROBOT)
    assert not env.corner_follows
    result = evaluate_fleet(env, pibt_policy(0), seeds=range(20))
    assert result.refused == 0
    assert result.delivered + result.walled_off == 20 * robots


@pytest.mark.parametrize("layout", [None, "aisles"])
@pytest.mark.parametrize("robots", [2, 3, 4])
def test_every_package_is_delivered_or_walled_off_by_a_parked_robot(layout, robots):
    env = fleet.parallel_env(num_robots=robots, layout=layout)
    result = evaluate_fleet(env, pibt_policy(0), seeds=range(20))
    assert result.refused == 0
    assert result.delivered + result.walled_off == 20 * robots


@pytest.mark.parametrize(("robots", "target"), [(128, 3.3), (192, 4.2)])
def test_throughput_on_the_kiva_warehouse_beats_the_published_figures(robots, target):
    """Lifelong, 256 steps, on the 33 x 46 floor of kiva-33-46.map (the ``warehouse``
    preset, the same floor): published figures are Follower 3.94, QMIX 2.0, RHCR 1.57
    and IQL 0.36 deliveries per step with 192 robots. One seed here; seeds 0-4 are
    ``benchmarks/fleet_scale.py``'s table (3.43 and 4.29)."""
    env = fleet.parallel_env(num_robots=robots, layout="warehouse", lifelong=True,
                             max_cycles=256)  # fmt: skip
    result = evaluate_throughput(env, pibt_policy(0), steps=256, seeds=range(1))
    assert result.refused == 0
    assert result.throughput >= target


def plans_digest(seed, moves="grid"):
    env = fleet.parallel_env(num_robots=60, layout="warehouse", lifelong=True, max_cycles=50,
                             moves=moves)  # fmt: skip
    policy = pibt_policy(seed)
    observations, infos = env.reset(seed=seed)
    digest = hashlib.sha256()
    for _ in range(50):
        actions = policy(env, observations, infos)
        digest.update(np.array([actions[a] for a in env.possible_agents]).tobytes())
        observations, _, _, _, infos = env.step(actions)
    return digest.hexdigest()


@pytest.fixture(scope="module")
def digests_in_another_process():
    """:func:`plans_digest` of seed 3 for four-direction and for turning robots, both from
    one fresh interpreter (what a user's script sees: nothing imported, nothing left over
    from other tests), started once for the two tests that compare with it; turning
    first there, so that neither case follows the other on both sides."""
    script = ("from tests.planners.test_pibt import plans_digest; "
              "print(plans_digest(3, 'rotate')); print(plans_digest(3))")  # fmt: skip
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            cwd=ROOT)  # fmt: skip
    assert result.returncode == 0, result.stderr
    rotate, grid = result.stdout.split()
    return {"grid": grid, "rotate": rotate}


def test_plans_are_bit_identical_across_processes_and_follow_the_seed(digests_in_another_process):
    here = plans_digest(3)
    assert digests_in_another_process["grid"] == here
    assert plans_digest(4) != here


def test_a_new_episode_starts_the_planner_afresh():
    env = fleet.parallel_env(num_robots=8, layout="aisles", lifelong=True, max_cycles=30)
    policy = pibt_policy(1)
    first = []
    for _ in range(2):
        observations, infos = env.reset(seed=2)
        actions = []
        for _ in range(30):
            step = policy(env, observations, infos)
            actions.append([step[a] for a in env.possible_agents])
            observations, _, _, _, infos = env.step(step)
        first.append(actions)
    assert first[0] == first[1]
    assert WAIT in np.array(first[0])  # waiting is part of a plan


MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def read_map(path):
    """A MovingAI map as a floor: ``@OTW`` blocked, every other symbol free."""
    lines = Path(path).read_text().splitlines()
    rows = lines[lines.index("map") + 1 :]
    return WarehouseGrid.from_layout(
        ["".join("#" if ch in "@OTW" else "." for ch in row) for row in rows if row]
    )


class FakeFleet:
    """Just the attributes :func:`pibt_policy` may read, for a lifelong fleet on ``grid``:
    robots on distinct free cells, packages uniform over the free cells (redrawn on
    arrival), moves granted by :func:`resolve_moves`. Slots: reading anything else fails."""

    __slots__ = ("agents", "corner_follows", "deliveries", "distances", "free", "grid",
                 "on_floor", "package_cells", "parked", "possible_agents", "refused", "rng",
                 "robot_cells", "steps")  # fmt: skip

    def __init__(self, grid, robots, seed, *, corner_follows=True):
        self.grid, self.corner_follows = grid, corner_follows
        self.distances = DistanceMaps(grid)
        self.rng = np.random.default_rng(seed)
        free = np.ones((grid.rows, grid.cols), dtype=bool)
        for row, col in grid.shelves:
            free[row, col] = False
        self.free = np.argwhere(free)
        self.robot_cells = self.free[self.rng.choice(len(self.free), robots, replace=False)]
        self.package_cells = self.free[self.rng.integers(len(self.free), size=robots)]
        self.parked = np.zeros(robots, dtype=bool)
        self.on_floor = np.ones(robots, dtype=bool)
        self.possible_agents = [f"robot_{i}" for i in range(robots)]
        self.agents = list(self.possible_agents)
        self.steps = self.deliveries = self.refused = 0

    def step(self, actions):
        assert set(actions) == set(self.agents)
        joint = np.array([actions[agent] for agent in self.possible_agents])
        self.robot_cells, refused = resolve_moves(self.grid, self.robot_cells, joint,
                                                  corner_follows=self.corner_follows)  # fmt: skip
        self.refused += int(refused.sum())
        arrived = (self.robot_cells == self.package_cells).all(axis=1)
        self.deliveries += int(arrived.sum())
        self.package_cells[arrived] = self.free[
            self.rng.integers(len(self.free), size=arrived.sum())
        ]
        self.steps += 1


@pytest.mark.skipif(not (MAPS / "kiva-33-46.map").exists(), reason=f"no {MAPS}/kiva-33-46.map")
def test_throughput_on_the_kiva_map_file_with_uniform_packages():
    """kiva-33-46.map as read from the file, 192 robots on random cells, packages uniform
    over the free cells, lifelong, 256 steps. The target, 4.2 deliveries per step, is for
    the mean over seeds 0-4: 3.96, 4.31, 4.38, 4.13, 4.22, mean 4.20 (128 robots: 3.54,
    3.34, 3.34, 3.48, 3.45, mean 3.43 against 3.3). One seed runs here, the lowest. (The
    fleet, whose packages avoid robots and each other, makes 4.42 and 3.45.)"""
    env = FakeFleet(read_map(MAPS / "kiva-33-46.map"), 192, seed=0)
    policy = pibt_policy(0)
    for _ in range(256):
        env.step(policy(env, {}, {}))
    assert env.refused == 0
    assert env.deliveries / 256 >= 3.85


@pytest.mark.parametrize("corner_follows", [True, False])
def test_two_robots_pass_each_other_out_of_a_pocket_left_by_parked_robots(corner_follows):
    """robot_1 stands in the corner pocket (3, 4) that parked robots close on the left;
    robot_0, first in priority, wants that cell. Pushing on cannot work: robot_0 steps
    back and pulls robot_1 out after it (the swap operation), and both arrive."""
    grid = WarehouseGrid(4, 5)
    cells = np.array([(2, 4), (3, 4), (3, 2), (3, 3)])
    goals = np.array([(3, 4), (3, 1), (3, 2), (3, 3)])
    movable = np.array([True, True, False, False])
    planner = PIBT(grid, corner_follows=corner_follows, seed=0)
    planner.plan(cells, goals, movable)
    planner._priority[:2] = [5.5, 0.5]  # robot_0 first
    arrived = np.zeros(2, dtype=bool)
    for _ in range(12):
        actions = planner.plan(cells, goals, movable & np.r_[~arrived, False, False])
        cells, refused = resolve_moves(grid, cells, actions, ~movable,
                                       corner_follows=corner_follows)  # fmt: skip
        assert not refused.any()
        arrived |= (cells[:2] == goals[:2]).all(axis=1)
    assert arrived.all()


# ------------------------------------------------------------------ turning robots
def test_turning_robots_keep_the_kiva_warehouse_moving_and_never_strand_a_robot():
    """Lifelong, 256 steps, 192 turning robots: every robot delivers (no deadlock), no
    move is refused, and the fleet delivers well above half the four-direction one's
    rate less the turns (``benchmarks/lorr.py`` has the full figures)."""
    env = fleet.parallel_env(num_robots=192, layout="warehouse", lifelong=True,
                             max_cycles=256, moves="rotate")  # fmt: skip
    result = evaluate_throughput(env, pibt_policy(0), steps=256, seeds=range(1))
    assert result.refused == 0
    assert result.throughput >= 2.5
    assert (env.deliveries > 0).all()


def test_turning_robots_pass_each_other_out_of_a_dead_end():
    """robot_1 faces out of the dead end (2, 1); robot_0, first in priority, stands in its
    mouth facing in, and wants that cell. Pushing on cannot work: robot_0 turns away and
    backs off, robot_1 follows it out (the swap operation, over several steps), and both
    arrive. Without the swap the two faced each other for ever."""
    grid = WarehouseGrid.from_layout(["....", "....", "#.##"])
    cols = grid.cols
    cells = np.array([(1, 1), (2, 1)])
    goals = np.array([(2, 1), (0, 3)])
    headings = np.array([1, 3])  # south, into the dead end; north, out of it
    planner = PIBT(grid, seed=0, moves="rotate")
    planner.plan(cells, goals, headings=headings)
    planner._priority[:] = [5.5, 0.5]  # robot_0 first
    arrived = np.zeros(2, dtype=bool)
    for _ in range(16):
        actions = planner.plan(cells, goals, ~arrived, headings=headings)
        grants = turning_moves(grid, cells[:, 0] * cols + cells[:, 1], headings, actions,
                               arrived)  # fmt: skip
        assert not grants.refused.any()
        cells = np.column_stack(np.divmod(grants.ends, cols))
        headings = grants.headings
        arrived |= (cells == goals).all(axis=1)
    assert arrived.all()


def test_turning_robots_keep_a_dense_random_floor_moving():
    """400 turning robots on a 32 x 32 floor with 20 % shelves at random (the LoRR main
    rounds' random floors' kind: many dead ends), lifelong, 600 steps: the last third
    delivers as much as the middle one (swap: 726 against 701). Without the swap operation
    the fleet jammed at dead ends and the last third fell to 379 (seeds 0-2 together: 1,981
    against 1,879 with the swap, 1,182 without; seed 1 alone, the clearest of the three
    without it, proves the same in a third of the time, and floors 0 and 2 are left out)."""
    seed = 1
    rows = random_floor(rows=32, cols=32, density=0.2, seed=seed)
    env = fleet.parallel_env(num_robots=400, layout=list(rows), starts="random",
                             lifelong=True, moves="rotate", max_cycles=600)  # fmt: skip
    policy = pibt_policy(seed)
    observations, infos = env.reset(seed=seed)
    done = []
    for _ in range(600):
        observations, _, _, _, infos = env.step(policy(env, observations, infos))
        done.append(int(env.deliveries.sum()))
    middle = done[399] - done[199]
    last = done[599] - done[399]
    assert last >= 0.95 * middle, (middle, last)


def test_turning_plans_are_bit_identical_across_processes(digests_in_another_process):
    here = plans_digest(3, "rotate")
    assert digests_in_another_process["rotate"] == here


def test_a_turning_planner_needs_headings_and_answers_a_request():
    grid = WarehouseGrid(3, 4)
    planner = PIBT(grid, seed=0, moves="rotate")
    with pytest.raises(ValueError, match="turning robots need one heading each"):
        planner.plan(np.array([[0, 0]]), np.array([[2, 3]]))
    # A person asks robot 0 to turn clockwise; robot 1, in robot 0's way east, is pushed on.
    actions = planner.plan(np.array([[0, 0], [0, 1]]), np.array([[2, 3], [0, 3]]),
                           headings=np.array([0, 0]), requests={0: 1})  # fmt: skip
    assert actions.tolist() == [1, 0]
    with pytest.raises(ValueError, match="moves must be one of"):
        PIBT(grid, moves="hop")
