"""Stable-Baselines3 and SuperSuit on the package's environments (the ``sb3`` extra).

Skipped unless the extra is installed (``pip install -e ".[sb3]"``); ``.ci/run``
installs it and runs this file.
"""

import textwrap
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason='needs the sb3 extra: pip install -e ".[sb3]"')
supersuit = pytest.importorskip("supersuit", reason='needs the sb3 extra: pip install -e ".[sb3]"')
torch = pytest.importorskip("torch", reason='needs the sb3 extra: pip install -e ".[sb3]"')

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.utils import set_random_seed  # noqa: E402
from stable_baselines3.common.vec_env import VecEnv, VecMonitor  # noqa: E402

import warehouse_phys  # noqa: E402
import warehouse_phys.rl.sb3 as sb3_module  # noqa: E402
from warehouse_phys import fleet  # noqa: E402
from warehouse_phys.rl.sb3 import SB3VecEnv, black_death, vec_env  # noqa: E402

GRID_ID, PHYSICS_ID = warehouse_phys.GRID_ENV_ID, warehouse_phys.PHYSICS_ENV_ID
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def one_thread():
    """Small networks train fastest on one thread, and reproducibly."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def greedy_results(model, env_id, **kwargs):
    """(targets reached by a shortest path, targets reached) of the greedy policy,
    one episode per target of the floor, within the 200-step limit."""
    env = gym.make(env_id, **kwargs)
    shortest = reached = 0
    for target in env.unwrapped.grid.target_cells:
        obs, info = env.reset(options={"target": target})
        optimal = info["optimal_steps"]
        for steps in range(1, 201):
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, _, _ = env.step(int(action))
            if terminated:
                reached += 1
                shortest += steps == optimal
                break
    return shortest, reached


# ---------------------------------------------------------------- the adapter
@pytest.mark.parametrize("env_id", [GRID_ID, PHYSICS_ID], ids=["grid", "phys"])
def test_the_adapter_is_a_vecenv_with_same_step_autoreset(env_id):
    envs = vec_env(env_id, num_envs=3, seed=0, monitor=False, max_episode_steps=5)
    assert isinstance(envs, VecEnv)
    assert isinstance(envs, SB3VecEnv)
    assert envs.observation_space == envs.native.single_observation_space
    obs = envs.reset()
    assert obs.shape == (3, 4)
    ended = 0
    for step in range(1, 11):
        envs.step_async(np.full(3, 2))  # RIGHT: nobody reaches a package in row > 0
        obs, rewards, dones, infos = envs.step_wait()
        assert rewards.dtype == np.float32
        assert isinstance(infos, list)
        assert len(infos) == 3
        assert dones.tolist() == [step % 5 == 0] * 3
        for i in np.flatnonzero(dones):
            ended += 1
            assert infos[i]["TimeLimit.truncated"]
            assert infos[i]["terminal_observation"][:2].tolist() == [0, 4]
            assert obs[i, :2].tolist() == [0, 0]  # the new episode's first observation
        assert all("optimal_steps" in info for info in infos)
    assert ended == 6


def test_a_terminated_episode_is_no_truncation_and_restarts_at_once():
    envs = vec_env(GRID_ID, num_envs=1, seed=0, monitor=False)
    obs = envs.reset()
    target = obs[0, 2:].tolist()
    path = [1] * target[0] + [2] * target[1]  # DOWN then RIGHT
    for action in path:
        obs, rewards, dones, infos = envs.step(np.array([action]))
    assert dones.tolist() == [True]
    assert rewards.tolist() == [1.0]
    assert not infos[0]["TimeLimit.truncated"]
    assert infos[0]["terminal_observation"][:2].tolist() == target
    assert obs[0, :2].tolist() == [0, 0]


def test_seed_reset_and_the_rest_of_the_api():
    def run(seed):
        envs = vec_env(GRID_ID, num_envs=4, seed=seed, observation="onehot", step_penalty=0.1)
        rng = np.random.default_rng(0)
        seen = [envs.reset()]
        for _ in range(30):
            seen.append(envs.step(rng.integers(4, size=4))[0])
        return envs, np.stack(seen)

    envs, first = run(7)
    assert isinstance(envs, VecMonitor)
    np.testing.assert_array_equal(first, run(7)[1])
    assert not np.array_equal(first, run(8)[1])
    assert first.dtype == np.float32
    assert first.shape[-1] == 18
    assert envs.get_attr("step_penalty") == [0.1] * 4
    assert envs.get_attr("grid_rows", indices=[1, 2]) == [4, 4]
    envs.set_attr("bump_penalty", 0.5)
    assert envs.unwrapped.native.bump_penalty == 0.5
    with pytest.raises(ValueError, match="every floor shares"):
        envs.set_attr("bump_penalty", 0.0, indices=[0])
    assert envs.env_method("render") == [None] * 4  # no render_mode
    assert envs.env_is_wrapped(gym.Wrapper) == [False] * 4
    envs.unwrapped.seed(3)
    np.testing.assert_array_equal(envs.reset(), run(3)[1][0])
    envs.close()


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="step_penalty"):
        vec_env(GRID_ID, num_envs=2, step_penalty=-1)
    with pytest.raises(TypeError, match="env_id"):
        vec_env(3)
    with pytest.raises(ValueError, match="no native vector environment"):
        vec_env("CartPole-v1", num_envs=2)
    native = gym.make_vec(GRID_ID, num_envs=2)
    assert vec_env(native, monitor=False).native is native
    with pytest.raises(ValueError, match="contradicts"):
        vec_env(native, num_envs=3)


# ---------------------------------------------------------------- the recipes
#: The docs page that holds the Stable-Baselines3 examples.
SB3_PAGE = ROOT / "docs" / "single-robot.md"


def docs_sb3_blocks():
    """The docs' Stable-Baselines3 blocks (plain fences: ``tests/test_docs.py`` runs only
    the ``python`` ones, and these need the extra), by the algorithm they import."""
    blocks, lines, plain = [], None, False  # lines: the open block's, if one is open
    for line in SB3_PAGE.read_text().splitlines(keepends=True):
        if lines is None:
            if line.startswith("```"):
                lines, plain = [], line == "```\n"
        elif line == "```\n":
            if plain:
                blocks.append("".join(lines))
            lines = None
        else:
            lines.append(line)
    return {
        algorithm: block
        for block in blocks
        for algorithm in ("PPO", "DQN")
        if f"from stable_baselines3 import {algorithm}\n" in block
    }


def docstring_recipes():
    """Every literal block (after a line ending in ``::``) of ``warehouse_phys.rl.sb3``'s
    docstring, dedented, in order."""
    lines = sb3_module.__doc__.splitlines()
    blocks = []
    for i, line in enumerate(lines):
        if line.rstrip().endswith("::"):
            body = []
            for following in lines[i + 1 :]:
                if following.strip() and not following.startswith("    "):
                    break
                body.append(following)
            blocks.append(textwrap.dedent("\n".join(body)).strip() + "\n")
    return blocks


def run_block(block):
    """Run ``block`` as a script's body and give back its names."""
    names = {"__name__": "recipe"}
    exec(compile(block, "recipe", "exec"), names)
    return names


def recipe(algorithm):
    """The module docstring's first recipe that trains ``algorithm`` (the docs hold it)."""
    imports = f"from stable_baselines3 import {algorithm}\n"
    return next(block for block in docstring_recipes() if imports in block)


def run_pinning_recipe(block, capsys):
    """Run ``block`` with PyTorch on two threads, as on a two-core machine by default; it
    must pin one itself. Returns its names and what it printed."""
    torch.set_num_threads(2)
    names = run_block(block)
    assert torch.get_num_threads() == 1  # the recipe pinned it
    return names, capsys.readouterr().out


def test_the_docs_blocks_are_the_docstring_recipes():
    docs = docs_sb3_blocks()
    assert set(docs) == {"PPO", "DQN"}
    assert docs["PPO"] == recipe("PPO")
    assert docs["DQN"] == recipe("DQN")


@pytest.mark.slow
def test_the_ppo_recipe_pins_one_thread_and_prints_what_its_comment_says(capsys):
    block = recipe("PPO")
    assert "# all 12 targets reached, at least 10 by a shortest path" in block
    names, printed = run_pinning_recipe(block, capsys)
    model = names["model"]
    assert model.num_timesteps >= 20_000
    shortest, reached = greedy_results(model, GRID_ID, observation="onehot")
    assert reached == 12  # in about 5 s on one core
    assert shortest >= 10
    assert printed == names["evaluate_model"](model, observation="onehot").summary() + "\n"
    assert printed.startswith("all 12 targets reached")


@pytest.mark.slow
def test_the_dqn_recipe_stays_optimal_at_100k_steps_and_says_so(capsys):
    # With the sparse reward alone DQN's defaults learn this floor by 50k steps and
    # lose it again by 100k (0 of 12 targets); with a step penalty they keep it.
    # About a minute on one core.
    block = recipe("DQN")
    assert "# all 12 targets reached by a shortest path" in block
    names, printed = run_pinning_recipe(block, capsys)
    assert greedy_results(names["model"], GRID_ID) == (12, 12)
    assert printed == "all 12 targets reached by a shortest path\n"


# ------------------------------------------------------------- evaluate_model
@pytest.mark.parametrize(
    ("algorithm", "env_id", "kwargs"),
    [
        ("PPO", GRID_ID, {"observation": "onehot"}),
        ("DQN", GRID_ID, {}),
        ("PPO", PHYSICS_ID, {"layout": "maze"}),
        ("DQN", GRID_ID, {"layout": "depot", "observation": "onehot"}),
    ],
)
def test_evaluate_model_is_the_policy_played_episode_by_episode(algorithm, env_id, kwargs):
    # Untrained networks: policies of every shape, most targets missed or reached late.
    from stable_baselines3 import DQN

    envs = vec_env(env_id, num_envs=2, seed=0, **kwargs)
    model = {"PPO": PPO, "DQN": DQN}[algorithm]("MlpPolicy", envs, seed=3, device="cpu")
    evaluation = sb3_module.evaluate_model(model, env_id, **kwargs)
    assert (evaluation.optimal, evaluation.reached) == greedy_results(model, env_id, **kwargs)
    assert len(evaluation.results) == len(gym.make(env_id, **kwargs).unwrapped.grid.target_cells)


def test_evaluate_model_refuses_a_floor_too_big_for_its_table(monkeypatch):
    monkeypatch.setattr(sb3_module, "TRAINING_MEMORY_BUDGET", 1000)
    model = PPO("MlpPolicy", vec_env(GRID_ID, num_envs=1, seed=0), device="cpu")
    with pytest.raises(ValueError, match=r"a 4x5 floor's table of actions would take more than"):
        sb3_module.evaluate_model(model)


def test_every_other_recipe_of_the_module_docstring_runs_as_written():
    """The recipes the docs do not hold (the fleet's), run in order in one namespace,
    as a reader pasting them into one session would; the docs' are run above."""
    in_docs = {recipe("PPO"), recipe("DQN")}
    others = [block for block in docstring_recipes() if block not in in_docs]
    assert len(others) == 2  # SuperSuit with one shared policy; black_death
    names = {"__name__": "recipe"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # from SuperSuit's own code
        exec(compile(others[0], "supersuit recipe", "exec"), names)
        assert names["model"].num_timesteps >= 2_048
        assert names["envs"].num_envs == 8  # 4 robots x 2 fleets, one policy
        exec(compile(others[1], "black_death recipe", "exec"), names)
        envs = names["envs"]
        envs.reset()
        envs.step(np.zeros(envs.num_envs, dtype=np.int64))


# ---------------------------------------------------------------- SuperSuit
def supersuit_ppo(robots, steps=512):
    envs = supersuit.pettingzoo_env_to_vec_env_v1(robots)
    envs = supersuit.concat_vec_envs_v1(envs, 2, num_cpus=0, base_class="stable_baselines3")
    envs.venv.reset(seed=0)  # SuperSuit's SB3 wrapper cannot take PPO(seed=...)
    set_random_seed(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # from SuperSuit's own code
        model = PPO("MlpPolicy", envs, n_steps=64, batch_size=64, device="cpu")
        model.learn(steps)
    return model, envs


@pytest.mark.parametrize("observation", ["onehot", "neighbours_onehot"])
def test_supersuit_trains_ppo_on_the_fleet(observation):
    robots = fleet.parallel_env(
        num_robots=3, observation=observation, on_delivery="new_package", max_cycles=40
    )
    model, envs = supersuit_ppo(robots)
    assert envs.num_envs == 6  # 3 robots x 2 fleets, one policy
    assert model.num_timesteps >= 512


def test_black_death_lets_robots_leave_under_supersuit():
    robots = black_death(
        fleet.parallel_env(num_robots=3, observation="onehot", on_delivery="leave", max_cycles=40)
    )
    model, _ = supersuit_ppo(robots, steps=1024)  # many episodes end with robots gone
    assert model.num_timesteps >= 1024
    obs, _ = robots.reset(seed=1)
    assert set(obs) == set(robots.possible_agents)
