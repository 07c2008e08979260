"""The fleet: PettingZoo's own test suites, the physics proofs of the traffic rule, the API."""

import copy
import functools
import pickle
import warnings

import numpy as np
import pytest

with warnings.catch_warnings():
    # pettingzoo.test imports one of PettingZoo's own classic games through an
    # import path that PettingZoo itself deprecates; not ours to fix.
    warnings.simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test

from warehouse_phys.envs import fleet
from warehouse_phys.physics import COLLISION_SLOP, SNAP_ERROR_BOUND, PhysicsConfig
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.traffic import WAIT, corner_follows_are_safe

WORLDS = {"grid": {"physics": False}, "physics": {"physics": True}}


def pettingzoo_quietly(test, *args, **kwargs):
    """Run one of PettingZoo's tests; its advisory warnings (about optional features
    such as `render_mode`) must not fail ours, which turn warnings into errors."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        test(*args, **kwargs)


# ------------------------------------------------------------- PettingZoo's suites
@pytest.mark.parametrize("observation", ["local", "global"])
@pytest.mark.parametrize("world", list(WORLDS))
def test_pettingzoos_parallel_and_aec_suites_pass(world, observation):
    kwargs = {"num_robots": 3, "observation": observation, "max_cycles": 60, **WORLDS[world]}
    pettingzoo_quietly(parallel_api_test, fleet.parallel_env(**kwargs), num_cycles=200)
    pettingzoo_quietly(parallel_seed_test, functools.partial(fleet.parallel_env, **kwargs), 100)
    pettingzoo_quietly(api_test, fleet.env(**kwargs), num_cycles=100)
    pettingzoo_quietly(seed_test, functools.partial(fleet.env, **kwargs), 50)


# ------------------------------------------------------------------ the proofs
FLOORS = {
    "default": {},
    "8x10": {"grid_rows": 8, "grid_cols": 10},
    "aisles": {"layout": "aisles"},
    "depot": {"layout": "depot"},
    "maze": {"layout": "maze"},
}


def random_run(kwargs, seed, steps):
    """Random joint actions (WAIT included; lifelong where the floor has the package
    cells for it, so that nobody parks for good); yields (observations, rewards, infos)."""
    try:
        env = fleet.parallel_env(lifelong=True, max_cycles=steps, **kwargs)
    except ValueError:  # too few package cells for a lifelong fleet (the depot's six docks)
        env = fleet.parallel_env(max_cycles=steps, **kwargs)
    rng = np.random.default_rng(seed)
    observations, infos = env.reset(seed=seed)
    yield observations, None, infos
    while env.agents:
        # Robots mostly head somewhere: traffic is dense and the rule is exercised.
        actions = {
            agent: int(rng.choice(5, p=[0.22, 0.22, 0.22, 0.22, 0.12])) for agent in env.agents
        }
        observations, rewards, _, _, infos = env.step(actions)
        yield observations, rewards, infos


@pytest.mark.parametrize("n_robots", [2, 4, 8])
@pytest.mark.parametrize("floor", list(FLOORS))
def test_bodies_end_on_the_grid_twins_cells_and_never_touch(floor, n_robots):
    kwargs = {"num_robots": n_robots, **FLOORS[floor]}
    if floor == "depot" and n_robots == 8:  # six docks: too few packages for eight robots
        with pytest.raises(ValueError, match="8 robots need 8 package cells"):
            fleet.parallel_env(**kwargs)
        return
    refusals = 0
    grid_run, phys_run = random_run(kwargs, 1, 120), random_run({**kwargs, "physics": True}, 1, 120)
    for (g_obs, g_rew, g_inf), (p_obs, p_rew, p_inf) in zip(grid_run, phys_run, strict=True):
        assert g_obs.keys() == p_obs.keys()
        for agent in g_obs:
            assert np.array_equal(g_obs[agent], p_obs[agent])  # Proof 1: the same cells
            assert p_inf[agent]["snap_error"] < SNAP_ERROR_BOUND
            # Proof 2: discs never closer than their diameter minus the collision slop.
            assert p_inf[agent]["min_gap"] > -COLLISION_SLOP
            assert g_inf[agent]["refused"] == p_inf[agent]["refused"]
            refusals += g_inf[agent]["refused"]
        assert g_rew == p_rew
    if n_robots > 2:
        assert refusals > 0  # traffic was exercised


def two_robot_world(starts, radius=0.3):
    config = PhysicsConfig(robot_radius=radius)
    grid = WarehouseGrid(3, 4)
    return BatchedPhysicsWorld(grid, config, starts, [0, 0], record_path=True), config


def closest_gap(world, config):
    paths = world.last_paths
    distance = np.linalg.norm(paths[0] - paths[1], axis=1).min()
    return distance - 2 * config.robot_radius / config.cell_size


@pytest.mark.parametrize(
    ("name", "starts", "aims", "expected"),
    [
        ("following at one cell", [(1, 0), (1, 1)], [(1, 1), (1, 2)], 1 - 0.6),
        ("turning into cells side by side", [(0, 1), (2, 0)], [(1, 1), (1, 0)], 1 - 0.6),
        ("waiting beside one that passes", [(1, 1), (0, 0)], [(1, 1), (0, 1)], 1 - 0.6),
        ("following round a corner", [(1, 0), (1, 1)], [(1, 1), (0, 1)], np.sqrt(0.5) - 0.6),
    ],
)
def test_the_tightest_granted_moves_keep_the_discs_apart(name, starts, aims, expected):
    world, config = two_robot_world(starts)
    cells, _ = world.move(np.array(aims))
    assert cells.tolist() == [list(a) for a in aims]
    gap = closest_gap(world, config)
    assert gap > -COLLISION_SLOP
    assert gap == pytest.approx(expected, abs=0.03), name


def test_a_forced_corner_follow_makes_robots_above_the_threshold_touch():
    # Proof 3: above the threshold the rule refuses corner follows; forced, discs touch.
    radius = 0.36  # diameter 0.72 > sqrt(0.5): corner follows are not granted
    assert not corner_follows_are_safe(2 * radius)
    world, config = two_robot_world([(1, 0), (1, 1)], radius=radius)
    world.move(np.array([(1, 1), (0, 1)]))
    assert closest_gap(world, config) < -COLLISION_SLOP
    # The default robot passes the same corner with room to spare.
    world, config = two_robot_world([(1, 0), (1, 1)])
    world.move(np.array([(1, 1), (0, 1)]))
    assert closest_gap(world, config) > 0.05
    # And the fleet of big robots refuses the follow.
    env = fleet.parallel_env(num_robots=2, physics=True, robot_radius=radius, grid_rows=3)
    assert env.corner_follows is False


# ----------------------------------------------------------------- the episode
def test_a_robot_that_delivers_parks_and_the_episode_ends_when_all_have():
    env = fleet.parallel_env(num_robots=2)
    observations, infos = env.reset(seed=9)  # a seed where one robot parks first
    rng = np.random.default_rng(0)
    rewards_seen = dict.fromkeys(env.possible_agents, 0.0)
    parked = set()
    steps_beside_a_parked_robot = 0
    for _ in range(400):
        if not env.agents:
            break
        actions = {}
        for agent in env.agents:  # straight to the package; a random move when refused
            row, col, p_row, p_col = observations[agent]
            toward = 1 if row < p_row else 3 if row > p_row else 2 if col < p_col else 0
            actions[agent] = int(rng.integers(5)) if infos[agent]["refused"] else toward
        observations, rewards, terminations, _, infos = env.step(actions)
        assert not parked & set(rewards)  # a parked robot no longer takes part
        for agent, reward in rewards.items():
            rewards_seen[agent] += reward
            assert terminations[agent] == (reward == 1.0)
            if terminations[agent]:
                parked.add(agent)
        # A parked robot stands on its package and delivers it no more.
        assert env.deliveries.tolist() == [int(a in parked) for a in env.possible_agents]
        steps_beside_a_parked_robot += len(env.agents) == 1
    assert steps_beside_a_parked_robot >= 2
    assert env.agents == []
    assert rewards_seen == {"robot_0": 1.0, "robot_1": 1.0}


def test_lifelong_robots_get_new_packages_and_count_deliveries():
    env = fleet.parallel_env(num_robots=3, lifelong=True, max_cycles=300)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    total = 0.0
    while env.agents:
        _, rewards, terminations, _, infos = env.step({a: int(rng.integers(5)) for a in env.agents})
        total += sum(rewards.values())
        assert not any(terminations.values())
        state = env.state().reshape(3, 4)
        packages = [tuple(p) for p in state[:, 2:]]
        assert len(set(packages)) == 3
        for i, agent in enumerate(env.possible_agents):
            if rewards[agent]:  # a new package, on no robot's cell
                assert packages[i] not in {tuple(c) for c in state[:, :2]}
    assert total == sum(info["deliveries"] for info in infos.values()) > 0


@pytest.mark.parametrize("world", list(WORLDS))
def test_copies_and_pickles_continue_alike(world):
    env = fleet.parallel_env(num_robots=3, **WORLDS[world])
    env.reset(seed=2)
    rng = np.random.default_rng(1)
    for _ in range(10):
        env.step({a: int(rng.integers(5)) for a in env.agents})
    for duplicate in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        original = copy.deepcopy(env)
        check = np.random.default_rng(4)
        for _ in range(20):
            if not original.agents:
                break
            actions = {a: int(check.integers(5)) for a in original.agents}
            a, b = original.step(actions), duplicate.step(actions)
            for x, y in zip(a[:4], b[:4], strict=True):
                assert x.keys() == y.keys()
            assert all(np.array_equal(a[0][k], b[0][k]) for k in a[0])
            assert a[4] == b[4]


@pytest.mark.parametrize(
    ("actions", "error", "message"),
    [
        ({"robot_0": 0}, ValueError, r"no action for \['robot_1'\]"),
        ({"robot_0": 0, "robot_1": 5}, ValueError, "robot_1's action must be 0..4"),
        ({"robot_0": 0.0, "robot_1": 1}, TypeError, "robot_0's action must be an integer"),
        ({"robot_0": 0, "robot_1": 1, "robot_9": 1}, ValueError, "not live"),
        ([0, 1], TypeError, "actions must be a dict"),
        ({"robot_0": 2**63, "robot_1": 1}, ValueError, "robot_0's action must be 0..4"),
        ({"robot_0": np.uint64(2**63), "robot_1": 1}, ValueError, "robot_0's action must be"),
        ({"robot_0": -(2**70), "robot_1": 1}, ValueError, "robot_0's action must be 0..4"),
        ({"robot_0": np.ma.masked_array(2, mask=True), "robot_1": 1}, ValueError,
         "robot_0's action is masked: it has no value"),
    ],
)  # fmt: skip
def test_bad_actions_are_refused_and_change_nothing(actions, error, message):
    env = fleet.parallel_env(num_robots=2, lifelong=True)
    env.reset(seed=0)
    before, generator = env.state(), env.np_random.bit_generator.state
    with pytest.raises(error, match=message):
        env.step(actions)
    assert np.array_equal(env.state(), before)
    assert env.np_random.bit_generator.state == generator
    assert env.steps == 0
    reference = fleet.parallel_env(num_robots=2, lifelong=True)
    reference.reset(seed=0)
    for _ in range(20):  # and it goes on as if the bad call never happened
        joint = {"robot_0": 2, "robot_1": 1}
        assert env.step(joint)[1] == reference.step(joint)[1]
        assert np.array_equal(env.state(), reference.state())


def test_frames_show_every_robot_in_its_colour():
    env = fleet.parallel_env(num_robots=3, render_mode="rgb_array", cell_px=32)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (4 * 32 + 20, 5 * 32, 3)
    assert frame.dtype == np.uint8
    ansi = fleet.parallel_env(num_robots=3, render_mode="ansi")
    ansi.reset(seed=0)
    text = ansi.render()
    assert all(str(i) in text and "abc"[i] in text for i in range(3))
    assert ansi.step(dict.fromkeys(ansi.agents, WAIT))[4]["robot_0"]["refused"] is False


# ------------------------------------------------- delivery modes, starts, scale
@pytest.mark.parametrize("observation", ["local", "neighbours", "global"])
@pytest.mark.parametrize("on_delivery", ["leave", "new_package", "park"])
def test_pettingzoos_suites_pass_for_every_delivery_mode_and_observation(on_delivery, observation):
    kwargs = {"num_robots": 3, "observation": observation, "on_delivery": on_delivery,
              "max_cycles": 40}  # fmt: skip
    pettingzoo_quietly(parallel_api_test, fleet.parallel_env(**kwargs), num_cycles=100)
    pettingzoo_quietly(parallel_seed_test, functools.partial(fleet.parallel_env, **kwargs), 40)
    pettingzoo_quietly(api_test, fleet.env(**kwargs), num_cycles=60)


def test_a_robot_that_leaves_frees_its_cell():
    env = fleet.parallel_env(num_robots=2, on_delivery="leave", grid_rows=2, grid_cols=3)
    env.reset(seed=0)
    env._cells = np.array([(1, 1), (1, 2)])
    env._packages = np.array([(1, 0), (1, 1)])
    _, rewards, terminations, _, _ = env.step({"robot_0": 0, "robot_1": 0})
    # robot_1 follows robot_0 straight onto its package: delivered, and gone.
    assert rewards == {"robot_0": 1.0, "robot_1": 1.0}
    assert terminations == {"robot_0": True, "robot_1": True}
    assert env.on_floor.tolist() == [False, False]
    assert env.agents == []
    env.reset(seed=0)
    env._cells = np.array([(1, 1), (1, 2)])
    env._packages = np.array([(1, 0), (0, 0)])
    env.step({"robot_0": 0, "robot_1": WAIT})  # robot_0 delivers and leaves (1, 0)
    assert env.agents == ["robot_1"]
    assert not env.on_floor[0]
    env.step({"robot_1": 0})
    env.step({"robot_1": 0})
    assert env.robot_cells[1].tolist() == [1, 0]  # through the cell robot_0 left
    with pytest.raises(ValueError, match="read-only"):
        env.robot_cells[0, 0] = 3


def test_the_neighbours_mask_marks_adjacent_robots_on_the_floor():
    env = fleet.parallel_env(num_robots=12, observation="neighbours", layout="aisles",
                             starts="random")  # fmt: skip
    assert env.observation_space("robot_0").nvec.tolist() == [7, 9, 7, 9, 16]
    rng = np.random.default_rng(0)
    observations, _ = env.reset(seed=5)
    for _ in range(30):
        cells = {tuple(c) for c in env.robot_cells.tolist()}
        for agent, obs in observations.items():
            row, col = obs[:2]
            expected = sum(
                bit
                for (d_row, d_col), bit in zip([(0, -1), (1, 0), (0, 1), (-1, 0)],
                                               fleet.NEIGHBOUR_BITS, strict=True)
                if (row + d_row, col + d_col) in cells
            )  # fmt: skip
            assert obs[4] == expected, agent
        observations, *_ = env.step({a: int(rng.integers(5)) for a in env.agents})


def test_random_starts_are_distinct_reachable_and_follow_the_seed():
    kwargs = {"num_robots": 20, "layout": "aisles", "starts": "random"}
    a, b = fleet.parallel_env(**kwargs), fleet.parallel_env(**kwargs)
    a.reset(seed=1)
    b.reset(seed=1)
    assert np.array_equal(a.state(), b.state())
    cells = [tuple(c) for c in a.robot_cells.tolist()]
    assert len(set(cells)) == 20
    assert set(cells) <= set(a.grid.reachable)
    b.reset(seed=2)
    assert not np.array_equal(a.robot_cells, b.robot_cells)


def test_ten_thousand_robots_step_on_one_floor():
    env = fleet.parallel_env(num_robots=10_000, grid_rows=150, grid_cols=150,
                             on_delivery="new_package", starts="random")  # fmt: skip
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(2):
        actions = dict(zip(env.agents, rng.integers(5, size=10_000).tolist(), strict=True))
        observations, rewards, *_ = env.step(actions)
    assert len(observations) == len(rewards) == 10_000
    flat = env.robot_cells[:, 0] * 150 + env.robot_cells[:, 1]
    assert len(np.unique(flat)) == 10_000
    with pytest.raises(ValueError, match="10,001 robots need 20,002 cells a robot can reach"):
        fleet.parallel_env(num_robots=10_001, grid_rows=100, grid_cols=200, starts="random")


def test_a_physics_fleet_beyond_the_old_cap_steps_without_touching():
    n = 2048  # the physics world took at most 1,024 robots; now what the memory holds
    env = fleet.parallel_env(num_robots=n, physics=True, grid_rows=64, grid_cols=64,
                             starts="random")  # fmt: skip
    env.reset(seed=0)
    actions = np.random.default_rng(0).integers(5, size=n).tolist()
    _, _, _, _, infos = env.step(dict(zip(env.agents, actions, strict=True)))
    assert min(info["min_gap"] for info in infos.values()) > -COLLISION_SLOP
    assert max(info["snap_error"] for info in infos.values()) < SNAP_ERROR_BOUND


def test_the_aec_form_refuses_a_bad_action_before_anything_changes():
    env = fleet.env(num_robots=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"robot_0's action must be 0\.\.4"):
        env.step(7)
    with pytest.raises(ValueError, match="robot_0's action is masked"):
        env.step(np.ma.masked_array(WAIT, mask=True))
    with pytest.raises(ValueError, match=r"robot_0's action must be 0\.\.4"):
        env.step(np.uint64(2**64 - 1))
    env.step(WAIT)  # still robot_0's turn: nothing was stored
    env.step(WAIT)
    assert env.unwrapped.steps == 1


def test_frames_mark_a_delivered_robot_and_keep_colours_apart():
    from warehouse_phys.drawing.colours import DELIVERED_FRAME, FLEET_COLOURS

    colours = np.array(FLEET_COLOURS, dtype=float)
    apart = np.linalg.norm(colours[:, None] - colours[None, :], axis=-1)
    np.fill_diagonal(apart, np.inf)
    assert apart.min() > 60  # the first eight stay distinct
    assert np.linalg.norm(colours - 245, axis=-1).min() > 60  # none passes for the floor
    env = fleet.parallel_env(num_robots=2, render_mode="rgb_array", cell_px=32)
    env.reset(seed=0)
    env._cells = np.array([(1, 1), (3, 4)])
    env._packages = np.array([(1, 2), (2, 2)])
    env.step({"robot_0": 2, "robot_1": WAIT})  # robot_0 delivers on (1, 2) and parks
    frame = env.render()
    assert (frame[1 * 32 + 1, 2 * 32 + 1] == DELIVERED_FRAME).all()
    assert not (frame[3 * 32 + 1, 4 * 32 + 1] == DELIVERED_FRAME).all()


# ------------------------------------------------- one-hot observations (issue 23)
@pytest.mark.parametrize(("onehot", "plain"), [("onehot", "local"),
                                               ("neighbours_onehot", "neighbours")])  # fmt: skip
def test_onehot_observations_encode_the_local_view(onehot, plain):
    kwargs = {"num_robots": 3, "on_delivery": "new_package", "max_cycles": 30}
    coded = fleet.parallel_env(observation=onehot, **kwargs)
    cells = fleet.parallel_env(observation=plain, **kwargs)
    rows, cols = coded.grid.rows, coded.grid.cols
    width = 2 * rows + 2 * cols + (4 if plain == "neighbours" else 0)
    assert coded.observation_space("robot_0") == gym_box(width)
    obs, _ = coded.reset(seed=2)
    expected, _ = cells.reset(seed=2)
    rng = np.random.default_rng(0)
    while coded.agents:
        for agent in coded.agents:
            assert obs[agent] in coded.observation_space(agent)
            view = expected[agent]
            hot = (view[:4] + np.array([0, rows, rows + cols, 2 * rows + cols])).tolist()
            if plain == "neighbours":  # the mask's bits after the one-hot cells
                hot += [2 * rows + 2 * cols + k for k in range(4) if view[4] >> k & 1]
            assert np.flatnonzero(obs[agent]).tolist() == sorted(hot)
        actions = {agent: int(rng.integers(5)) for agent in coded.agents}
        obs = coded.step(actions)[0]
        expected = cells.step(actions)[0]


def gym_box(width):
    from gymnasium import spaces

    return spaces.Box(0.0, 1.0, (width,), np.float32)


@pytest.mark.parametrize("observation", ["onehot", "neighbours_onehot"])
def test_pettingzoos_suites_pass_with_onehot_observations(observation):
    kwargs = {"num_robots": 3, "observation": observation, "on_delivery": "leave",
              "max_cycles": 40}  # fmt: skip
    pettingzoo_quietly(parallel_api_test, fleet.parallel_env(**kwargs), num_cycles=100)
    pettingzoo_quietly(parallel_seed_test, functools.partial(fleet.parallel_env, **kwargs), 40)
    pettingzoo_quietly(api_test, fleet.env(**kwargs), num_cycles=60)


# ------------------------------------------------ integers beyond int64 (issue 32)
@pytest.mark.parametrize(
    ("actions", "message"),
    [
        ({"robot_0": 10**5000, "robot_1": 1}, r"^robot_0's action must be 0..4 \(4 is WAIT\), "
         r"got an integer of 16610 bits$"),
        ({"robot_0": 1, "robot_1": -(10**5000)}, r"^robot_1's action must be 0..4 \(4 is WAIT\), "
         r"got a negative integer of 16610 bits$"),
    ],
)  # fmt: skip
def test_actions_with_thousands_of_digits_are_refused_by_robot(actions, message):
    env = fleet.parallel_env(num_robots=2)
    env.reset(seed=0)
    before = env.state()
    with pytest.raises(ValueError, match=message):
        env.step(actions)
    assert np.array_equal(env.state(), before)
    assert env.steps == 0


def test_a_fleet_with_more_packages_than_its_distance_maps_hold_runs_on_guide_paths():
    """Distance maps bounded to two: the other robots' packages are guided (the fleet once
    refused such a fleet at every reset). Deliveries happen, the maps stay in their
    bound, every robot's ``optimal_steps`` is at least its true distance, and exactly it
    for the robots whose packages have maps."""
    from warehouse_phys.planners.distances import DistanceMaps
    from warehouse_phys.rl.fleet_planners import pibt_policy

    env = fleet.parallel_env(num_robots=12, layout="aisles", on_delivery="new_package",
                             max_cycles=120)  # fmt: skip
    probe = DistanceMaps(env.grid)
    env.distances = DistanceMaps(env.grid, max_bytes=2 * probe._map_bytes)
    with pytest.raises(ValueError, match="distances must be a DistanceMaps of this fleet"):
        env.distances = DistanceMaps(WarehouseGrid(4, 5))
    policy = pibt_policy(seed=0)
    observations, infos = env.reset(seed=0)
    delivered = 0
    for _ in range(100):  # within the episode's 120 steps
        observations, _, _, _, infos = env.step(policy(env, observations, infos))
        delivered += sum(info["deliveries"] for info in infos.values())
        cols = env.grid.cols
        cells = env.robot_cells[:, 0] * cols + env.robot_cells[:, 1]
        goals = env.package_cells[:, 0] * cols + env.package_cells[:, 1]
        truth = probe.lookup(cells, goals)
        optimal = np.array([infos[a]["optimal_steps"] for a in env.agents])
        assert (optimal >= truth).all()
        mapped = env.distances._row_of_goal[goals] >= 0
        np.testing.assert_array_equal(optimal[mapped], truth[mapped])
    assert env.distances.maps <= 2
    assert env.distances.guided >= 8
    assert delivered > 0
