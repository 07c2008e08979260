"""Tabular Q-learning as a library: the update, the schedule, records, evaluation, save and load."""

import io
import json
import os
import pickle
import zipfile

import gymnasium as gym
import numpy as np
import pytest

import warehouse_phys
import warehouse_phys.envs.fleet
from warehouse_phys import Action
from warehouse_phys.rl.fleet_learning import train_fleet
from warehouse_phys.rl.greedy_policy import evaluate
from warehouse_phys.rl.qlearning import (
    TABLE_FORMAT,
    QLearningConfig,
    QTableError,
    check_training_memory,
    epsilon_greedy,
    epsilon_schedule,
    load_q_table,
    new_q_table,
    save_q_table,
    table_metadata,
    td_update,
    train,
)

GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID


@pytest.fixture(scope="module")
def trained():
    """The default run on the grid twin (about 0.2 s)."""
    env = gym.make(GRID_ID)
    return env, train(env, QLearningConfig())


# ------------------------------------------------------------------- config
def test_defaults_are_the_tutorials():
    config = QLearningConfig()
    assert (config.episodes, config.alpha, config.gamma, config.seed) == (1000, 0.9, 0.9, 0)
    assert config.epsilon(0) == 1.0
    assert config.epsilon(1) == pytest.approx(1 - 1 / 1000)
    assert config.epsilon(500) == pytest.approx(0.5)
    assert config.epsilon(1000) == 0.0
    assert config.epsilon(5000) == 0.0


def test_every_learner_plays_the_one_epsilon_schedule(trained):
    _, result = trained
    schedule = epsilon_schedule(result.config.episodes)
    assert schedule.dtype == np.float64
    np.testing.assert_array_equal(result.epsilon, schedule)
    assert [result.config.epsilon(i) for i in range(len(schedule))] == schedule.tolist()
    fleet_env = warehouse_phys.envs.fleet.parallel_env(num_robots=2)
    fleet_result = train_fleet(fleet_env, QLearningConfig(episodes=7))
    np.testing.assert_array_equal(fleet_result.epsilon, epsilon_schedule(7))


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"episodes": 0}, ValueError, "episodes must be at least 1, got 0"),
        ({"episodes": 2.5}, TypeError, "episodes must be an integer"),
        ({"alpha": 0.0}, ValueError, r"alpha must be in \(0, 1\], got 0.0"),
        ({"alpha": 1.5}, ValueError, "alpha must be in"),
        ({"gamma": -0.1}, ValueError, r"gamma must be in \[0, 1\]"),
        ({"gamma": "0.9"}, TypeError, "gamma must be a number"),
        ({"seed": -1}, ValueError, "seed must be non-negative"),
    ],
)
def test_bad_hyper_parameters_are_refused(kwargs, error, message):
    with pytest.raises(error, match=message):
        QLearningConfig(**kwargs)


# ------------------------------------------------------------------ training
def test_the_update_rule_on_a_hand_worked_episode():
    """Two episodes with alpha=0.5, gamma=0.5 on a 2x2 floor, checked by hand."""
    env = gym.make(GRID_ID, grid_rows=2, grid_cols=2)
    # A 2x2 floor has one target cell, (1, 1); all exploration: epsilon is 1 in episode 0.
    result = train(env, QLearningConfig(episodes=1, alpha=0.5, gamma=0.5, seed=4))
    q = result.q
    # Replay the same actions to see the transitions the agent saw.
    rng = np.random.default_rng([4, 1])
    expected = new_q_table(2, 2)
    state = (0, 0, 1, 1)
    for _ in range(result.steps[0]):
        rng.random()  # the explore/exploit draw; epsilon = 1 always explores
        action = int(rng.integers(4))
        nxt = (*env.unwrapped.grid.move(state[:2], action), 1, 1)
        reward = 1.0 if nxt[:2] == (1, 1) else 0.0
        target = reward if reward else reward + 0.5 * expected[nxt].max()
        expected[(*state, action)] += 0.5 * (target - expected[(*state, action)])
        state = nxt
    assert state[:2] == (1, 1)
    assert np.array_equal(q, expected)
    assert q.max() == 0.5  # the last step earned half of the reward of 1


def test_no_bootstrap_from_a_terminal_state():
    env = gym.make(GRID_ID, grid_rows=2, grid_cols=2)
    # Start from a table of 5s: bootstrapping from the target's state would add 0.9 * 5.
    start = np.full((2, 2, 2, 2, 4), 5.0)
    result = train(env, QLearningConfig(episodes=300, alpha=1.0, gamma=0.9, seed=0), q=start)
    # With alpha=1 each value is its last target: stepping onto the target is worth exactly 1.
    assert result.q[0, 1, 1, 1, Action.DOWN] == 1.0
    assert result.q[1, 0, 1, 1, Action.RIGHT] == 1.0
    # One step further back: gamma times that.
    assert result.q[0, 0, 1, 1, Action.RIGHT] == pytest.approx(0.9)
    assert (start == 5.0).all()  # the initial table was copied, not changed


def test_the_shared_update_and_choice_rules():
    values, next_values = np.array([0.0, 0.5, 0.0, 0.0]), np.array([0.2, 0.8, 0.8, 0.1])
    td_update(values, 2, 0.0, next_values, alpha=0.5, gamma=0.9)
    assert values[2] == pytest.approx(0.5 * 0.9 * 0.8)
    td_update(values, 0, 1.0, None, alpha=0.5, gamma=0.9)  # terminal: the reward alone
    assert values[0] == 0.5
    rng = np.random.default_rng(0)
    assert epsilon_greedy(next_values, 0.0, rng) == 1  # the first of the best
    picked = {epsilon_greedy(next_values, 0.0, rng, random_ties=True) for _ in range(50)}
    assert picked == {1, 2}
    # Without ties and at epsilon 0 the fleet's rule draws nothing.
    state = rng.bit_generator.state
    assert epsilon_greedy(np.array([0.0, 0.9, 0.5, 0.1]), 0.0, rng, random_ties=True) == 1
    assert rng.bit_generator.state == state


def test_training_can_carry_on_from_a_table(trained):
    env, result = trained
    more = train(env, QLearningConfig(episodes=5, seed=9), q=result.q)
    assert evaluate(env, more.q).all_optimal
    with pytest.raises(ValueError, match="does not match its 3x3 grid"):
        train(gym.make(GRID_ID, grid_rows=3, grid_cols=3), QLearningConfig(), q=result.q)


def test_records_have_one_entry_per_episode(trained):
    _, result = trained
    assert len(result.steps) == len(result.returns) == len(result.reached_target) == 1000
    assert result.epsilon[0] == 1.0
    assert result.epsilon[-1] == pytest.approx(0.001)
    assert np.array_equal(result.returns, result.reached_target.astype(float))
    assert result.reached_target.all()
    assert not result.truncated.any()
    assert result.steps[-100:].mean() < result.steps[:100].mean() / 3


def test_truncated_episodes_are_counted_as_such():
    # A 2x2 floor (one target, 2 steps away) and a 2-step time limit: an episode either
    # walks straight there, arriving on the very step the time limit also fires, or is cut.
    env = gym.make(GRID_ID, grid_rows=2, grid_cols=2, max_episode_steps=2)
    result = train(env, QLearningConfig(episodes=200, seed=1))
    assert (result.steps == 2).all()
    assert 20 < result.reached_target.sum() < 200
    # Arriving on the last allowed step is reaching the target, not a truncation.
    assert not (result.truncated & result.reached_target).any()
    assert result.truncated.sum() + result.reached_target.sum() == 200
    assert (result.returns[result.truncated] == 0).all()
    assert (result.returns[result.reached_target] == 1).all()


def test_training_is_deterministic_and_seeded(trained):
    _, result = trained
    again = train(gym.make(GRID_ID), QLearningConfig())
    assert np.array_equal(result.q, again.q)
    assert np.array_equal(result.steps, again.steps)
    other = train(gym.make(GRID_ID), QLearningConfig(seed=1))
    assert not np.array_equal(result.steps, other.steps)


def test_both_worlds_learn_the_same_table():
    """Same seed, same trajectories: the physics-backed run learns bit for bit the same table."""
    config = QLearningConfig(episodes=150, seed=2)
    grid = train(gym.make(GRID_ID, grid_rows=3, grid_cols=4), config)
    phys = train(gym.make(PHYS_ID, grid_rows=3, grid_cols=4), config)
    assert np.array_equal(grid.q, phys.q)
    assert np.array_equal(grid.steps, phys.steps)


def test_progress_callback_sees_every_episode():
    seen = []
    train(gym.make(GRID_ID), QLearningConfig(episodes=7), on_episode=seen.append)
    assert seen == list(range(7))


def test_a_non_warehouse_environment_is_refused():
    with pytest.raises(ValueError, match="not a warehouse environment"):
        train(gym.make("FrozenLake-v1"), QLearningConfig(episodes=1))


# -------------------------------------------------------------- save and load
def test_save_and_load_round_trip(tmp_path, trained):
    env, result = trained
    path = save_q_table(tmp_path / "q.npz", result.q, table_metadata(env, result.config))
    q, metadata = load_q_table(path)
    assert np.array_equal(q, result.q)
    assert q.dtype == np.float64
    assert metadata == {
        "format": TABLE_FORMAT,
        "format_version": 1,
        "env_id": GRID_ID,
        "grid_rows": 4,
        "grid_cols": 5,
        "episodes": 1000,
        "alpha": 0.9,
        "gamma": 0.9,
        "seed": 0,
        "package_version": warehouse_phys.__version__,
        "layout": None,
        "layout_name": None,
    }
    # The loaded table evaluates the same as the trained one.
    assert evaluate(env, q) == evaluate(env, result.q)
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


def test_saving_over_an_old_table_replaces_it(tmp_path, trained):
    env, result = trained
    path = tmp_path / "q.npz"
    meta = table_metadata(env, result.config)
    save_q_table(path, new_q_table(4, 5), meta)
    save_q_table(path, result.q, meta)
    assert np.array_equal(load_q_table(path)[0], result.q)


def test_a_failed_save_leaves_no_half_written_file(tmp_path, trained, monkeypatch):
    env, result = trained
    path = tmp_path / "q.npz"
    meta = table_metadata(env, result.config)
    save_q_table(path, result.q, meta)
    before = path.read_bytes()

    def fail_half_way(file, **arrays):
        file.write(b"PK\x03\x04 half an archive")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", fail_half_way)
    with pytest.raises(OSError, match="disk full"):
        save_q_table(path, new_q_table(4, 5), meta)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["q.npz"]
    with pytest.raises(OSError, match="disk full"):
        save_q_table(tmp_path / "new.npz", result.q, meta)
    assert not (tmp_path / "new.npz").exists()


def test_saving_a_table_that_would_not_load_is_refused(tmp_path, trained):
    env, result = trained
    meta = table_metadata(env, result.config)
    bad = result.q.copy()
    bad[0, 0, 1, 1, 0] = np.nan
    with pytest.raises(QTableError, match="NaN or infinite"):
        save_q_table(tmp_path / "q.npz", bad, meta)
    with pytest.raises(QTableError, match="does not match its 4x5 grid"):
        save_q_table(tmp_path / "q.npz", new_q_table(3, 3), meta)
    assert not (tmp_path / "q.npz").exists()


class _Explode:
    """Unpickling this would create the file named in its argument."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def write_npz(path, **arrays):
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in arrays.items():
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, data, allow_pickle=True)
            archive.writestr(f"{name}.npy", buffer.getvalue())


def good_metadata(**changes):
    meta = {
        "format": TABLE_FORMAT,
        "format_version": 1,
        "env_id": GRID_ID,
        "grid_rows": 4,
        "grid_cols": 5,
        "episodes": 10,
        "alpha": 0.9,
        "gamma": 0.9,
        "seed": 0,
        "package_version": "0.1.0",
        "layout": None,
        "layout_name": None,
    }
    meta.update(changes)
    return np.array(json.dumps(meta))


def test_pickle_payloads_are_refused_and_never_run(tmp_path):
    marker = tmp_path / "pwned"
    pickled = tmp_path / "table.pkl"
    pickled.write_bytes(pickle.dumps(_Explode(str(marker))))
    with pytest.raises(QTableError, match="holds pickled data, which is never loaded"):
        load_q_table(pickled)
    obj = np.empty((), dtype=object)
    obj[()] = _Explode(str(marker))
    inside = tmp_path / "object.npz"
    write_npz(inside, q=obj, metadata=good_metadata())
    with pytest.raises(QTableError, match="object array, which needs pickle"):
        load_q_table(inside)
    assert not marker.exists()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: None, "no such file"),
        (lambda p: p.mkdir(), "not a file"),
        (lambda p: p.write_text("q = [[0, 1]]\n"), "not an .npz archive"),
        (lambda p: np.save(p.with_suffix(".npy"), np.zeros(3)) or os.replace(
            p.with_suffix(".npy"), p), "not an .npz archive"),
        (lambda p: write_npz(p, metadata=good_metadata()), "has no 'q' array"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4))), "has no 'metadata' array"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4)), metadata=np.array("{nope")),
         "metadata is not valid JSON"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4)), metadata=np.zeros(2)),
         "metadata is not a JSON string"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4)), metadata=good_metadata(
            grid_rows="4")), "metadata 'grid_rows' has the wrong type"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4)), metadata=good_metadata(
            format="other")), "not a warehouse_phys.qtable file"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4)), metadata=good_metadata(
            format_version=9)), "format version 9 is not supported"),
        (lambda p: write_npz(p, q=np.zeros((3, 3, 3, 3, 4)), metadata=good_metadata()),
         r"table shape \(3, 3, 3, 3, 4\) does not match its 4x5 grid"),
        (lambda p: write_npz(p, q=np.full((4, 5, 4, 5, 4), np.inf), metadata=good_metadata()),
         "NaN or infinite values"),
        (lambda p: write_npz(p, q=np.zeros((4, 5, 4, 5, 4), dtype="U1"), metadata=good_metadata()),
         "expected real floats"),
    ],
)  # fmt: skip
def test_unusable_files_are_refused_with_the_reason(tmp_path, make, message):
    path = tmp_path / "table.npz"
    make(path)
    with pytest.raises(QTableError, match=message) as caught:
        load_q_table(path)
    assert str(path) in str(caught.value)


def test_a_truncated_table_is_refused(tmp_path, trained):
    env, result = trained
    path = save_q_table(tmp_path / "q.npz", result.q, table_metadata(env, result.config))
    data = path.read_bytes()
    for cut in (len(data) // 2, len(data) - 30, 40):
        path.write_bytes(data[:cut])
        with pytest.raises(QTableError, match="truncated or corrupt"):
            load_q_table(path)


def test_a_table_for_one_grid_is_refused_for_another(tmp_path, trained):
    env, result = trained
    path = save_q_table(tmp_path / "q.npz", result.q, table_metadata(env, result.config))
    assert load_q_table(path, rows=4, cols=5)[0].shape == (4, 5, 4, 5, 4)
    with pytest.raises(QTableError, match="the table is for a 4x5 grid, not 3x3"):
        load_q_table(path, rows=3, cols=3)


# -------------------------------------------------------------------- layouts
@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(warehouse_phys.PRESETS))
@pytest.mark.parametrize("seed", [0, 1])
def test_the_recommended_episodes_learn_every_preset_optimally(name, seed):
    """On the grid twin, which learns exactly the table the physics twin learns."""
    env = gym.make(warehouse_phys.preset_ids(name)[0])
    episodes = warehouse_phys.PRESETS[name].training_episodes
    result = train(env, QLearningConfig(episodes=episodes, seed=seed))
    evaluation = evaluate(env, result.q)
    assert evaluation.all_optimal, evaluation.table()
    # Shortest paths around the shelves, not Manhattan distances.
    grid = env.unwrapped.grid
    assert [r.optimal_steps for r in evaluation.results] == [
        grid.optimal_steps(grid.start, r.target) for r in evaluation.results
    ]


def test_both_worlds_learn_the_same_table_around_shelves():
    config = QLearningConfig(episodes=120, seed=5)
    layout = ["S.#.", "..#P", "...."]
    grid = train(gym.make(GRID_ID, layout=layout, max_episode_steps=100), config)
    phys = train(gym.make(PHYS_ID, layout=layout, max_episode_steps=100), config)
    assert np.array_equal(grid.q, phys.q)


def test_a_layout_travels_with_its_table(tmp_path):
    env = gym.make("warehouse-robot-maze-v0")
    result = train(env, QLearningConfig(episodes=20))
    meta = table_metadata(env, result.config)
    assert meta["env_id"] == "warehouse-robot-maze-v0"
    assert meta["layout"] == list(warehouse_phys.PRESETS["maze"].rows)
    assert meta["layout_name"] == "maze"
    q, loaded = load_q_table(save_q_table(tmp_path / "q.npz", result.q, meta))
    assert loaded["layout"] == meta["layout"]
    assert q.shape == (5, 7, 5, 7, 4)
    custom = gym.make(GRID_ID, layout=["S.#", "..P"])
    assert table_metadata(custom, QLearningConfig())["layout_name"] is None


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"layout": ["S.#", "..x"], "grid_rows": 2, "grid_cols": 3}, "not a valid layout"),
        ({"layout": ["S.#", "..P"]}, "metadata 'layout' is 2x3, not the 4x5 grid it names"),
        ({"layout": "S.#"}, "metadata 'layout' has the wrong type"),
    ],
)
def test_a_table_with_a_bad_layout_is_refused(tmp_path, changes, message):
    path = tmp_path / "table.npz"
    rows, cols = changes.get("grid_rows", 4), changes.get("grid_cols", 5)
    write_npz(path, q=np.zeros((rows, cols, rows, cols, 4)), metadata=good_metadata(**changes))
    with pytest.raises(QTableError, match=message):
        load_q_table(path)


# ------------------------------------------------------------ crafted archives
def npy_bytes(header_text, data=b""):
    """An NPY member with this header text, version 1.0, padded as numpy pads it."""
    header = header_text.encode("latin1")
    length = len(header) + 1
    pad = (64 - (10 + length) % 64) % 64
    header += b" " * pad + b"\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + data


def raw_npz(path, members, *, compress=zipfile.ZIP_DEFLATED):
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            info = zipfile.ZipInfo(f"{name}.npy")
            info.compress_type = compress
            archive.writestr(info, data)


def metadata_member(**changes):
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, good_metadata(**changes))
    return buffer.getvalue()


def table_member(array):
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array)
    return buffer.getvalue()


def patch_headers(path, field, value):
    """Rewrite a 2-byte field of every entry's local and central header: "flags" or "method"."""
    offsets = {"flags": (6, 8), "method": (8, 10)}[field]
    data = bytearray(path.read_bytes())
    for signature, offset in zip((b"PK\x03\x04", b"PK\x01\x02"), offsets, strict=True):
        start = 0
        while (start := data.find(signature, start)) >= 0:
            data[start + offset : start + offset + 2] = value.to_bytes(2, "little")
            start += 4
    path.write_bytes(bytes(data))


ZEROS = np.zeros((4, 5, 4, 5, 4))
TRUNCATED_HEADER = "{'descr': '<f8', 'fortran_order': False, 'shape': (4, 5"
NEGATIVE_SHAPE = "{'descr': '<f8', 'fortran_order': False, 'shape': (-4,), }"


def huge_shape(p):
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (10000000, 10000000), }"
    raw_npz(p, {"q": npy_bytes(header, b"\0" * 64), "metadata": metadata_member()})


def nested_metadata(p):
    text = "[" * 40_000 + "]" * 40_000  # 320 KB: under the size cap, too deep to parse
    write_npz(p, q=ZEROS, metadata=np.array(text))


def huge_number(p):
    text = json.dumps(json.loads(str(good_metadata()))).replace(
        '"seed": 0', '"seed": 1' + "0" * 5000
    )
    write_npz(p, q=ZEROS, metadata=np.array(text))


def longdouble_overflow(p):
    write_npz(p, q=np.full((4, 5, 4, 5, 4), np.longdouble("1e400")), metadata=good_metadata())


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (huge_shape, r"array 'q' declares shape \(10000000, 10000000\) of float64, "
                     r"800000000000000 bytes, more than the 25600 it may hold"),
        (nested_metadata, r"metadata is not valid JSON \(nested too deeply\)"),
        (huge_number, r"metadata is not valid JSON \(Exceeds the limit"),
        (lambda p: raw_npz(p, {"q": b"not an array", "metadata": metadata_member()}),
         "array 'q' is not NPY data"),
        (lambda p: raw_npz(p, {"q": table_member(ZEROS), "metadata": b"\x93NUMPY\x01"}),
         "array 'metadata' is not NPY data"),
        (lambda p: (raw_npz(p, {"q": table_member(ZEROS), "metadata": metadata_member()}),
                    patch_headers(p, "flags", 1)),
         "member 'q.npy' is encrypted"),
        (lambda p: raw_npz(p, {"q": npy_bytes(TRUNCATED_HEADER), "metadata": metadata_member()}),
         "array 'q' is not NPY data"),
        (lambda p: raw_npz(p, {"q": npy_bytes(NEGATIVE_SHAPE), "metadata": metadata_member()}),
         "array 'q' is not NPY data|invalid shape"),
        (lambda p: (raw_npz(p, {"q": table_member(ZEROS), "metadata": metadata_member()}),
                    patch_headers(p, "method", 99)),
         "member 'q.npy' uses zip compression method 99; numpy's archives are stored or deflated"),
        (lambda p: raw_npz(p, {"q": table_member(ZEROS), "metadata": metadata_member()},
                           compress=zipfile.ZIP_LZMA),
         "uses zip compression method 14"),
        (longdouble_overflow, "table holds NaN or infinite values"),
        (lambda p: write_npz(p, q=ZEROS.astype(np.int64), metadata=good_metadata()),
         "table has dtype int64, expected real floats"),
        (lambda p: write_npz(p, q=ZEROS.astype(np.complex128), metadata=good_metadata()),
         "table has dtype complex128, expected real floats"),
        (lambda p: write_npz(p, q=ZEROS[..., :2], metadata=good_metadata()),
         r"table shape \(4, 5, 4, 5, 2\) does not match its 4x5 grid"),
        (lambda p: write_npz(p, q=np.zeros((5, 7, 5, 7, 4)), metadata=good_metadata(
            grid_rows=5, grid_cols=7, layout=list(warehouse_phys.PRESETS["maze"].rows),
            layout_name="depot", env_id="warehouse-robot-maze-v0")),
         "metadata 'layout_name' is 'depot', but its layout is the preset 'maze'"),
        (lambda p: write_npz(p, q=np.zeros((2, 3, 2, 3, 4)), metadata=good_metadata(
            grid_rows=2, grid_cols=3, layout=["S.#", "..P"], layout_name="nowhere")),
         "metadata 'layout_name' is 'nowhere', but its layout is not a preset's"),
        (lambda p: write_npz(p, q=ZEROS, metadata=good_metadata(layout_name="maze")),
         "metadata names the layout 'maze' but holds no layout"),
        (lambda p: write_npz(p, q=ZEROS, metadata=good_metadata(env_id="CartPole-v1")),
         "metadata 'env_id' 'CartPole-v1' is not a warehouse environment"),
        (lambda p: write_npz(p, q=ZEROS, metadata=good_metadata(env_id="warehouse-robot-maze-v0")),
         "is a preset's, but holds no layout"),
        (lambda p: write_npz(p, q=ZEROS, metadata=good_metadata(alpha=0)),
         "metadata 'alpha' is out of range: 0"),
        (lambda p: write_npz(p, q=ZEROS, metadata=good_metadata(episodes=-3)),
         "metadata 'episodes' is out of range: -3"),
        (lambda p: write_npz(p, q=ZEROS, metadata=good_metadata(grid_rows=10**3000)),
         "metadata 'grid_rows' is out of range: a huge number"),
    ],
)  # fmt: skip
def test_crafted_archives_are_refused_in_one_line(tmp_path, make, message):
    path = tmp_path / "table.npz"
    make(path)
    with pytest.raises(QTableError, match=message) as caught:
        load_q_table(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: ")
    assert "\n" not in text
    assert len(text) < 400


def test_oversized_metadata_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "table.npz"
    chars = 25 * 2**20  # 100 MiB of text as numpy's 4-byte characters; compresses to kilobytes
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("q.npy", table_member(ZEROS))
        header = f"{{'descr': '<U{chars}', 'fortran_order': False, 'shape': (), }}"
        with archive.open("metadata.npy", "w", force_zip64=True) as member:
            member.write(npy_bytes(header))
            block = " ".encode("utf-32-le") * 2**18
            for _ in range(chars // 2**18):
                member.write(block)
    assert path.stat().st_size < 2**20
    message = r"array 'metadata' declares .* bytes, more than"
    assert peak_memory_of_refusing(path, message) < 4 * 2**20


def test_a_huge_declared_table_allocates_nothing(tmp_path):
    path = tmp_path / "table.npz"
    huge_shape(path)
    assert peak_memory_of_refusing(path, "declares shape") < 2 * 2**20


def peak_memory_of_refusing(path, message):
    """The most memory Python held while ``load_q_table`` refused ``path`` [bytes]."""
    import tracemalloc

    tracemalloc.start()
    try:
        with pytest.raises(QTableError, match=message):
            load_q_table(path)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_float32_table_loads_as_float64(tmp_path):
    path = tmp_path / "table.npz"
    q32 = np.random.default_rng(0).random((4, 5, 4, 5, 4)).astype(np.float32)
    write_npz(path, q=q32, metadata=good_metadata())
    q, _ = load_q_table(path)
    assert q.dtype == np.float64
    assert np.array_equal(q, q32.astype(np.float64))


# ------------------------------------------------------------- memory budget
def test_a_table_over_the_memory_budget_is_refused_before_allocation():
    with pytest.raises(
        ValueError, match=r"a 300x300 floor needs a Q-table of 241\.4 GiB, more than"
    ):
        new_q_table(300, 300)
    with pytest.raises(ValueError, match=r"and 999999999999 episodes need 23\.6 TiB of records"):
        check_training_memory(4, 5, 999_999_999_999)
    check_training_memory(64, 64, 1_000_000)  # 512 MiB of table, 25 MiB of records: fine


def test_train_checks_the_budget_before_it_allocates():
    env = gym.make(GRID_ID)
    with pytest.raises(ValueError, match=r"more than the 2\.0 GiB a training run may take"):
        train(env, QLearningConfig(episodes=999_999_999_999))
