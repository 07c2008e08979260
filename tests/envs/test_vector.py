"""The native grid vector environment: what only it does (what both native vector envs do
is in test_vector_shared.py)."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import SyncVectorEnv
from gymnasium.wrappers.vector import RecordEpisodeStatistics

from tests.envs.vector_kinds import GRID_FLOORS, GRID_ID, SHELVES
from warehouse_phys.world.batched import BatchedRules
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import resolve_layout


# ------------------------------------------------------------------ the rules
@pytest.mark.parametrize(
    "grid",
    [WarehouseGrid(4, 5), WarehouseGrid(3, 9), resolve_layout("maze"),
     WarehouseGrid.from_layout(SHELVES)],
    ids=["4x5", "3x9", "maze", "shelves"],
)  # fmt: skip
def test_batched_tables_are_the_grids_rules(grid):
    rules = BatchedRules(grid)
    cols = grid.cols
    for cell in grid.reachable:
        for action in range(4):
            to = grid.move(cell, action)
            assert rules.moves[(cell[0] * cols + cell[1]) * 4 + action] == to[0] * cols + to[1]
    assert [
        (r, c) for r, c in zip(rules.rows[rules.targets], rules.cols[rules.targets], strict=True)
    ] == [tuple(t) for t in grid.target_cells]
    table = rules.distance_table().reshape(len(rules.targets), -1)
    for slot, target in enumerate(grid.target_cells):
        for cell in grid.reachable:
            assert table[slot, cell[0] * cols + cell[1]] == grid.optimal_steps(cell, target)
        cells = np.array([c[0] * cols + c[1] for c in sorted(grid.reachable)])
        expected = [grid.optimal_steps(c, target) for c in sorted(grid.reachable)]
        targets = np.full(len(cells), rules.index(target))
        assert rules.optimal_steps(cells, targets).tolist() == expected


# ------------------------------------------------------------------------ make_vec
def test_gymnasiums_own_vectorisation_stays_available():
    envs = gym.make_vec(GRID_ID, num_envs=2, vectorization_mode="sync")
    assert isinstance(envs, SyncVectorEnv)


# ---------------------------------------------------------------------- targets
def chi_square_uniform(counts):
    """The chi-square statistic of ``counts`` against a uniform distribution, and its
    bound: mean + 6 standard deviations of the statistic under uniformity."""
    counts = np.asarray(counts, dtype=float)
    expected = counts.sum() / len(counts)
    statistic = ((counts - expected) ** 2 / expected).sum()
    dof = len(counts) - 1
    return statistic, dof + 6 * np.sqrt(2 * dof)


@pytest.mark.parametrize("name", ["default", "maze", "depot", "aisles"])
def test_packages_are_drawn_uniformly_from_the_target_cells_never_on_the_start(name):
    env_id, kwargs = GRID_FLOORS[name]
    envs = gym.make_vec(env_id, num_envs=4096, **kwargs)
    grid = envs.unwrapped.grid
    index = {tuple(cell): i for i, cell in enumerate(grid.target_cells)}
    counts = np.zeros(len(index))
    for seed in range(12):
        obs, _ = envs.reset(seed=seed)
        for target in map(tuple, obs[:, 2:].tolist()):
            counts[index[target]] += 1  # a KeyError here: a package off the target cells
    assert tuple(grid.start) not in index
    statistic, bound = chi_square_uniform(counts)
    assert statistic < bound
    # The test has teeth: one cell drawn twice as often as its share fails it.
    biased = counts.copy()
    biased[0] *= 2
    assert chi_square_uniform(biased)[0] > bound


# ---------------------------------------------------------- refused reset, actions
@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"reset_mask": [True, False]}, TypeError, "must be a numpy array of bools, got list"),
        ({"reset_mask": np.array([1, 0])}, TypeError, "numpy array of bools, got ndarray of int64"),
        ({"reset_mask": np.array([True])}, ValueError, r"must have shape \(2,\), got \(1,\)"),
        ({"reset_mask": np.array([False, False])}, ValueError, "at least one sub-environment"),
        ({"target": (1, 1)}, ValueError, r"unknown reset option\(s\) 'target'"),
        (5, TypeError, "reset options must be a dict or None, got int"),
        ({"reset_mask": np.ma.masked_array([True, True], mask=[0, 1])}, ValueError,
         r"^options\['reset_mask'\] has a masked entry \(sub-environment 1\)"),
        ({"reset_mask": np.ma.masked_array([True, False], mask=True)}, ValueError,
         r"^options\['reset_mask'\] has a masked entry \(sub-environment 0\)"),
    ],
)  # fmt: skip
def test_bad_reset_options_are_refused_and_change_nothing(options, error, message):
    envs = gym.make_vec(GRID_ID, num_envs=2)
    obs, _ = envs.reset(seed=0)
    state = envs.unwrapped.np_random.bit_generator.state
    with pytest.raises(error, match=message):
        envs.reset(seed=5, options=options)
    assert envs.unwrapped.np_random.bit_generator.state == state
    assert np.array_equal(envs.step(np.zeros(2, dtype=int))[0][:, 2:], obs[:, 2:])


@pytest.mark.parametrize(
    ("actions", "error", "message"),
    [
        (np.array([0, 1, 2]), ValueError, r"must have shape \(2,\), one per sub-environment"),
        (np.array([0.0, 1.0]), TypeError, "actions must be integers in 0..3 .* got dtype float64"),
        (np.array([True, False]), TypeError, "got dtype bool"),
        (np.array([0, 4]), ValueError, "sub-environment 1 got 4"),
        (np.array([-1, -2]), ValueError, r"sub-environment 0 got -1 \(and 1 more\)"),
        (np.array([2, 300], dtype=np.uint16), ValueError, "sub-environment 1 got 300"),
        (5, ValueError, r"actions must have shape \(2,\)"),
        (np.array([0, 4], dtype=">i8"), ValueError, "sub-environment 1 got 4"),
        (np.array([1, 2], dtype="m8"), TypeError, "got dtype timedelta64"),
        ([1, [2, 3]], ValueError,
         r"^actions must be an array of shape \(2,\) of integers in 0..3; numpy cannot make an "
         r"array of this list: setting an array element with a sequence"),
        ([1, np.ma.masked], ValueError, "sub-environment 1's is masked"),
        (np.ma.masked_array([1, 2], mask=[1, 0]), ValueError, "sub-environment 0's is masked"),
        # issue 32: beyond int64, masked 0-d values, bools and floats in a list
        ([2**63, 0], ValueError, "^actions must be .*: sub-environment 0 got 9223372036854775808$"),
        ([np.uint64(2**63), 1], ValueError, "sub-environment 0 got 9223372036854775808$"),
        ([1, -(2**64)], ValueError, "sub-environment 1 got a negative integer of 65 bits$"),
        ([10**5000, 0], ValueError, "sub-environment 0 got an integer of 16610 bits$"),
        ([np.int8(2), np.uint64(4)], ValueError, "sub-environment 1 got 4$"),
        ([np.ma.masked_array(1, mask=True), 0], ValueError, "sub-environment 0's is masked"),
        ((0, np.ma.masked), ValueError, "sub-environment 1's is masked"),
        (np.ma.masked, ValueError, r"actions must have shape \(2,\)"),
        (np.ma.masked_array(1, mask=True), ValueError, r"actions must have shape \(2,\)"),
        ([0, True], TypeError, "sub-environment 1's is a bool, not an integer"),
        ([np.bool_(False), 1], TypeError, "sub-environment 0's is a bool, not an integer"),
        ([np.int8(2), 1.0], TypeError, "got dtype float64"),
        ([np.uint64(1), np.timedelta64(1)], TypeError, "got dtype"),
    ],
)  # fmt: skip
def test_invalid_actions_are_refused_and_change_nothing(actions, error, message):
    envs = gym.make_vec(GRID_ID, num_envs=2)
    obs, _ = envs.reset(seed=0)
    with pytest.raises(error, match=message) as caught:
        envs.step(actions)
    assert "\n" not in str(caught.value)
    again, *_ = envs.step(np.array([3, 0]))  # into the walls: nothing moves
    assert np.array_equal(again, obs)
    assert envs.unwrapped._steps.tolist() == [1, 1]


def test_stepping_before_reset_is_refused():
    envs = gym.make_vec(GRID_ID, num_envs=2)
    with pytest.raises(gym.error.ResetNeeded):
        envs.step(np.zeros(2, dtype=int))


# ----------------------------------------------------------------- wrappers, arrays
def test_record_episode_statistics_counts_the_episodes():
    envs = RecordEpisodeStatistics(gym.make_vec(GRID_ID, num_envs=16))
    envs.reset(seed=0)
    rng = np.random.default_rng(1)
    lengths, returns = [], []
    for _ in range(400):
        *_, infos = envs.step(rng.integers(4, size=16))
        if "episode" in infos:
            done = infos["_episode"]
            lengths += infos["episode"]["l"][done].tolist()
            returns += infos["episode"]["r"][done].tolist()
    assert len(lengths) > 50
    assert set(returns) <= {0.0, 1.0}
    assert max(lengths) <= 200


def test_returned_arrays_are_never_reused():
    envs = gym.make_vec(GRID_ID, num_envs=4)
    first, infos = envs.reset(seed=0)
    kept = first.copy(), infos["optimal_steps"].copy()
    second = envs.step(np.array([2, 1, 2, 1]))
    envs.step(np.array([2, 1, 2, 1]))
    assert np.array_equal(first, kept[0])
    assert np.array_equal(infos["optimal_steps"], kept[1])
    assert not np.shares_memory(second[0], envs.step(np.zeros(4, dtype=int))[0])


# ------------------------------------------------------- deep-RL options (issue 23)
def test_penalties_are_checked_by_name():
    for keyword in ("step_penalty", "bump_penalty"):
        with pytest.raises(ValueError, match=keyword):
            gym.make_vec(GRID_ID, num_envs=2, **{keyword: -1.0})
        with pytest.raises(TypeError, match=keyword):
            gym.make_vec(GRID_ID, num_envs=2, **{keyword: "1"})
    with pytest.raises(ValueError, match="observation must be one of"):
        gym.make_vec(GRID_ID, num_envs=2, observation="image")


def test_the_sb3_adapter_without_stable_baselines3_names_the_extra(monkeypatch):
    import sys

    from warehouse_phys.rl import sb3

    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    monkeypatch.setitem(sys.modules, "stable_baselines3.common", None)
    with pytest.raises(ImportError, match=r'pip install "warehouse_phys\[sb3\]"'):
        sb3.vec_env(GRID_ID, num_envs=2)


def test_a_masked_reset_mask_with_nothing_masked_is_a_mask():
    envs = gym.make_vec(GRID_ID, num_envs=2)
    envs.reset(seed=0)
    envs.step(np.array([2, 2]))
    mask = np.ma.masked_array([False, True], mask=False)
    obs, _ = envs.reset(options={"reset_mask": mask})
    assert obs[:, :2].tolist() == [[0, 1], [0, 0]]
