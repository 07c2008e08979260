"""Stable-Baselines3 on the package's native vector environments (the ``sb3`` extra).

Stable-Baselines3 has its own vector-environment API and cannot take what
``gym.make_vec`` returns. :func:`vec_env` makes the native vector environment
(:class:`~warehouse_phys.envs.vector.WarehouseGridVectorEnv`, or the physics-backed
:class:`~warehouse_phys.envs.vector_physics.WarehousePhysicsVectorEnv`) and wraps it in
``SB3VecEnv``, a real ``stable_baselines3.common.vec_env.VecEnv``: every
floor is still stepped with a few array operations, no Python loop over
environments. Install the extra first (``pip install "warehouse_phys[sb3]"``).

Every recipe below runs as written in ``tests/rl/test_sb3.py``, in the order given
(a later one may use the names an earlier one imported); the two that learn the
default floor are the documentation's (``docs/single-robot.md``), and the tests check what
their comments say.

Pin PyTorch to one thread first. By default it runs a thread per core, and for
networks this small the threads mostly wait on one another: on the 2-core
development machine, with other work keeping it busy (load 5 to 11), the PPO recipe
below took 64 to 136 s (32 to 66 s of CPU) with PyTorch's default two threads and 6 to
16 s (3 to 5 s of CPU) with one; the DQN recipe 62 s (42 s of CPU) with one thread,
and had not finished after 25 minutes with two. :func:`evaluate_model` plays the trained policy
from the start against every target, as ``python -m warehouse_phys.train``
evaluates its table, and says in a line how it did.

PPO on the grid twin, one-hot observations for the MLP. SB3's default rollout,
2,048 steps per floor, makes two updates in 20k steps, which reach 6 of the 12
targets; short rollouts and large batches (twenty updates) learn the floor::

    import torch
    from stable_baselines3 import PPO
    from warehouse_phys.rl.sb3 import evaluate_model, vec_env

    torch.set_num_threads(1)  # one thread: far faster for a network this small
    env = vec_env("warehouse-robot-v0", num_envs=8, seed=0, observation="onehot")
    model = PPO("MlpPolicy", env, seed=0, n_steps=128, batch_size=256, device="cpu")
    model.learn(20_000)
    print(evaluate_model(model, observation="onehot").summary())
    # all 12 targets reached, at least 10 by a shortest path

DQN with its defaults learns the default floor, but with the sparse reward
alone (nothing is lost by delaying, nothing by bumping into a wall) its policy
drifts away again as training goes on: with seed 0 it reaches 11 of the 12
targets by a shortest path at 50k steps and none at 75k and 100k. A step
penalty of 0.1 keeps it on the shortest paths (12 of 12 at 50k, 75k and 100k;
0.01 is too small: 4 of 12 at 100k)::

    import torch
    from stable_baselines3 import DQN
    from warehouse_phys.rl.sb3 import evaluate_model, vec_env

    torch.set_num_threads(1)
    env = vec_env("warehouse-robot-v0", num_envs=1, seed=0, step_penalty=0.1)
    model = DQN("MlpPolicy", env, seed=0, device="cpu")
    model.learn(100_000)
    print(evaluate_model(model).summary())  # all 12 targets reached by a shortest path

Any keyword of the single environment goes through (``grid_rows``, ``layout``,
``observation``, ``step_penalty``, ``bump_penalty``, the physical keywords of
``warehouse-robot-phys-v0``, ``max_episode_steps``), and so does any preset id.

What the adapter does with the native environment's conventions:

- Autoreset: the native environments restart an ended episode on the *next*
  step; Stable-Baselines3 expects it on the same step. The adapter restarts the
  ended floors at once (``reset(options={"reset_mask": done})``), returns their
  new episode's first observation and puts the last one in
  ``infos[i]["terminal_observation"]``, with ``infos[i]["TimeLimit.truncated"]``
  true for a floor truncated by the time limit without reaching its package.
  Each floor's episodes follow the single environment's rules exactly.
- Seeding: the native environment has one generator for every floor (as
  Gymnasium's ``CartPoleVectorEnv``). ``seed(s)`` (and ``vec_env(seed=s)``) seeds
  it with ``s`` at the next ``reset()``; the same seed gives the same episodes.
- Attributes and methods (``get_attr``, ``set_attr``, ``env_method``) are the
  native vector environment's, shared by every floor: ``get_attr`` gives its
  value once per index asked for; ``set_attr`` and ``env_method`` act on it once
  and refuse indices that leave floors out. ``env_is_wrapped`` is false: no
  floor is a wrapped Gymnasium environment.
- ``vec_env(..., monitor=True)`` (the default, as SB3's ``make_vec_env``) wraps
  the adapter in ``VecMonitor``, so that training logs episode returns and
  lengths and ``evaluate_policy`` counts whole episodes.

The fleet with SuperSuit: SuperSuit's ``pettingzoo_env_to_vec_env_v1`` turns a
PettingZoo ``ParallelEnv`` whose robots share one observation and action space
into a vector environment with one entry per robot, and ``concat_vec_envs_v1``
stacks copies of it into a Stable-Baselines3 ``VecEnv``. It needs a ``Box``
observation (``observation="onehot"`` or ``"neighbours_onehot"``) and robots that
stay for the whole episode (``on_delivery="new_package"`` or ``"park"``).
SuperSuit's ``SB3VecEnvWrapper`` cannot be seeded (its ``seed`` calls a method
``ConcatVecEnv`` lacks, so ``PPO(..., seed=0)`` fails): seed the fleets with
``envs.venv.reset(seed=0)`` and the networks with ``set_random_seed(0)``.

This recipe shows the wiring, one policy shared by every robot, with a budget
that only proves it runs: it is no solver. Its greedy policy delivers 0.00
packages a step (4 robots, 200 steps, seeds 0 to 4, measured with
``warehouse_phys.rl.fleet_evaluation.evaluate_throughput``); 0.03 with SB3's
default rollout and 20k steps, and 0.10 with ``n_steps=128, batch_size=256`` and
300k steps (4 minutes), where the PIBT planner
(``warehouse_phys.planners.pibt.pibt_policy``) delivers 1.52. No settings that
learn the fleet are known yet::

    import supersuit as ss
    from stable_baselines3 import PPO
    from stable_baselines3.common.utils import set_random_seed
    from warehouse_phys.envs import fleet

    robots = fleet.parallel_env(num_robots=4, observation="onehot",
                                on_delivery="new_package", max_cycles=200)
    envs = ss.pettingzoo_env_to_vec_env_v1(robots)
    envs = ss.concat_vec_envs_v1(envs, 2, num_cpus=0, base_class="stable_baselines3")
    envs.venv.reset(seed=0)
    set_random_seed(0)
    model = PPO("MlpPolicy", envs, n_steps=64, batch_size=64, device="cpu")
    model.learn(2_048)  # 8 robots (4 x 2 fleets) a step of the VecEnv: 256 steps

With ``on_delivery="leave"`` robots leave the floor, which SuperSuit's
vectoriser refuses; the recipe is SuperSuit's ``black_death_v3``, which keeps a
robot that left in the batch with zero observations and rewards until the
episode ends. SuperSuit 3.11's ``black_death_v3`` never ends an episode,
though (it waits for every robot to be terminated *and* truncated on one step;
SuperSuit's pull request #265 makes it *or*), so the fleet would be stepped
after its last robot left. :func:`black_death` is the same wrapper with that
fix; use it until a SuperSuit release has it::

    from warehouse_phys.rl.sb3 import black_death

    robots = black_death(
        fleet.parallel_env(num_robots=4, observation="onehot", on_delivery="leave")
    )
    envs = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(robots), 2,
                                 num_cpus=0, base_class="stable_baselines3")
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from warehouse_phys.envs.base import onehot
from warehouse_phys.envs.vector import WarehouseGridVectorEnv
from warehouse_phys.rl.greedy_policy import Evaluation, evaluate
from warehouse_phys.rl.qtable_file import TRAINING_MEMORY_BUDGET

if TYPE_CHECKING:  # pragma: no cover - the sb3 extra is optional
    from stable_baselines3.common.vec_env import VecEnv

INSTALL_HINT = 'pip install "warehouse_phys[sb3]"'

__all__ = [  # noqa: F822 - SB3VecEnv: see __getattr__
    "INSTALL_HINT",
    "SB3VecEnv",
    "black_death",
    "evaluate_model",
    "vec_env",
]


def __getattr__(name: str) -> Any:
    """``SB3VecEnv``, the adapter's class, built on SB3's ``VecEnv`` when first asked for."""
    if name == "SB3VecEnv":
        return _adapter_class(_import_sb3().VecEnv)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def evaluate_model(model: Any, env_id: str = "warehouse-robot-v0", **kwargs: Any) -> Evaluation:
    """How ``model``'s deterministic policy does on the single robot's floor: from the
    start against every target, as ``train`` evaluates a table
    (:func:`warehouse_phys.rl.greedy_policy.evaluate`; ``.summary()`` says it in a line).

    ``model`` is a Stable-Baselines3 model, or anything with its
    ``predict(observations, deterministic=True)``; ``env_id`` and ``kwargs`` make the
    environment it was trained on (``observation="onehot"``, a ``layout``, ...). The
    policy is asked once, in one batch, for its action on every reachable cell with the
    package on every target cell; the episodes are then played by the floor's rules.

    Raises:
        ValueError: if the table of those actions would take more than
            :data:`~warehouse_phys.rl.qtable_file.TRAINING_MEMORY_BUDGET` bytes, and as
            :func:`~warehouse_phys.rl.greedy_policy.evaluate`.
    """
    env = gym.make(env_id, **kwargs)
    try:
        base, grid = env.unwrapped, env.unwrapped.grid
        rows, cols = grid.rows, grid.cols
        if (rows * cols) ** 2 * 4 > TRAINING_MEMORY_BUDGET:
            raise ValueError(
                f"a {rows}x{cols} floor's table of actions would take more than "
                f"{TRAINING_MEMORY_BUDGET:,} bytes; evaluate on a smaller floor"
            )
        cells, goals = np.flatnonzero(grid.reachable_mask), grid.target_indices
        here, there = np.repeat(cells, len(goals)), np.tile(goals, len(cells))
        states = np.stack([here // cols, here % cols, there // cols, there % cols], axis=1)
        observations = onehot(states, rows, cols) if base.observation == "onehot" else states
        actions, _ = model.predict(observations, deterministic=True)
        table = np.zeros((rows, cols, rows, cols, 4), dtype=np.uint8)
        table[(*states.T, np.asarray(actions, dtype=np.int64).reshape(-1))] = 1
        return evaluate(env, table)
    finally:
        env.close()


def black_death(parallel_env: Any) -> Any:
    """SuperSuit's ``black_death_v3`` around ``parallel_env``, ending each episode once
    every robot still on the floor has terminated or been truncated.

    SuperSuit 3.11's wrapper ends an episode only when every robot is terminated
    *and* truncated on the same step, which never happens here, so the fleet would
    be stepped after its last robot left. This is the wrapper with *or* (the fix of
    SuperSuit's pull request #265). Needs a ``Box`` observation (``"onehot"``).

    Raises:
        ImportError: if SuperSuit is not installed (the ``sb3`` extra).
    """
    try:
        from supersuit.multiagent_wrappers.black_death import black_death_par
    except ImportError as error:
        raise ImportError(
            f"warehouse_phys.rl.sb3.black_death needs SuperSuit: `{INSTALL_HINT}`"
        ) from error

    class _BlackDeath(black_death_par):
        def step(self, actions: dict) -> tuple[dict, dict, dict, dict, dict]:
            active = {agent: actions[agent] for agent in self.env.agents}
            obs, rewards, terms, truncs, infos = self.env.step(active)
            done = all(terms[agent] or truncs[agent] for agent in terms)
            zeros = {
                agent: np.zeros_like(self.observation_space(agent).low)
                for agent in self.agents
                if agent not in obs
            }
            gone = [agent for agent in self.agents if agent not in obs]
            all_obs = {**zeros, **obs}
            all_rewards = {**dict.fromkeys(gone, 0.0), **rewards}
            all_infos = {**{agent: {} for agent in gone}, **infos}
            dones = dict.fromkeys(self.agents, done)
            if done:
                self.agents.clear()
            return all_obs, all_rewards, dones, dict(dones), all_infos

    return _BlackDeath(parallel_env)


def _import_sb3() -> Any:
    """``stable_baselines3.common.vec_env``, or an ``ImportError`` that says how to get it."""
    try:
        from stable_baselines3.common import vec_env
    except ImportError as error:
        raise ImportError(
            "warehouse_phys.rl.sb3 needs Stable-Baselines3, which is not installed: "
            f"install the sb3 extra with `{INSTALL_HINT}`"
        ) from error
    return vec_env


def vec_env(
    env_id: str | WarehouseGridVectorEnv = "warehouse-robot-v0",
    num_envs: int = 8,
    *,
    seed: int | None = None,
    monitor: bool = True,
    **kwargs: Any,
) -> VecEnv:
    """A Stable-Baselines3 ``VecEnv`` of ``num_envs`` floors, stepped as arrays.

    Args:
        env_id: A grid or physics id of the package (``"warehouse-robot-v0"``,
            ``"warehouse-robot-phys-v0"``, a preset's id, with or without the
            ``"warehouse_phys:"`` prefix), made with ``gym.make_vec(env_id,
            num_envs, vectorization_mode="vector_entry_point", **kwargs)``; or a
            native vector environment already made (then ``num_envs`` and
            ``kwargs`` must be left out).
        num_envs: How many floors.
        seed: Seeds the floors' generator at the first ``reset()``.
        monitor: Wrap the adapter in SB3's ``VecMonitor`` (episode statistics).
        **kwargs: The environment's keywords (``observation="onehot"``,
            ``step_penalty=0.01``, ``grid_rows=6``, ...).

    Raises:
        ImportError: if Stable-Baselines3 is not installed (the ``sb3`` extra).
        TypeError, ValueError: for an environment or arguments the package refuses.
    """
    sb3_vec_env = _import_sb3()
    if isinstance(env_id, WarehouseGridVectorEnv):
        if kwargs:
            raise TypeError(
                f"vec_env got a vector environment already made and keywords {sorted(kwargs)}; "
                "pass the keywords to gym.make_vec instead"
            )
        if num_envs not in (8, env_id.num_envs):  # 8: the default, left out
            raise ValueError(
                f"num_envs={num_envs} contradicts the vector environment's {env_id.num_envs}"
            )
        native = env_id
    elif isinstance(env_id, str):
        native = gym.make_vec(
            env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
        )
        if not isinstance(native, WarehouseGridVectorEnv):
            native.close()
            raise ValueError(
                f"{env_id!r} has no native vector environment of warehouse_phys "
                f"(gym.make_vec gave {type(native).__name__})"
            )
    else:
        raise TypeError(
            "env_id must be an environment id or a warehouse_phys vector environment, "
            f"got {env_id!r} ({type(env_id).__name__})"
        )
    adapter = _adapter_class(sb3_vec_env.VecEnv)(native)
    if seed is not None:
        adapter.seed(seed)
    return sb3_vec_env.VecMonitor(adapter) if monitor else adapter


_ADAPTER: type | None = None


def _adapter_class(base: type) -> type:
    """:class:`SB3VecEnv`'s class, built on SB3's ``VecEnv`` once it is imported."""
    global _ADAPTER
    if _ADAPTER is None:
        _ADAPTER = type("SB3VecEnv", (_SB3VecEnvMixin, base), {"__module__": __name__})
    return _ADAPTER


class _SB3VecEnvMixin:
    """The adapter's methods; the class is ``SB3VecEnv``, a subclass of SB3's ``VecEnv``.

    Built by :func:`vec_env`: ``SB3VecEnv(native)`` takes a native vector environment
    of the package and speaks Stable-Baselines3's ``VecEnv`` API over it (see the
    module's docstring for the conventions).
    """

    def __init__(self, native: WarehouseGridVectorEnv) -> None:
        #: The native vector environment every floor lives in.
        self.native = native
        self._actions: np.ndarray | None = None
        super().__init__(
            native.num_envs, native.single_observation_space, native.single_action_space
        )
        self.metadata = {**self.metadata, "autoreset_mode": "same-step"}

    # ------------------------------------------------------------------ stepping
    def reset(self) -> np.ndarray:
        """Start new episodes on every floor; seeded by the last :meth:`seed`, once."""
        if any(self._options):
            raise ValueError(
                "warehouse_phys vector environments take no per-floor reset options "
                f"(set_options gave {self._options[0]!r}); make the environment with the "
                "keywords instead"
            )
        seed = self._seeds[0]
        obs, infos = self.native.reset(seed=seed)
        self.reset_infos = _split_infos(infos, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        self._actions = None
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Keep ``actions`` (one per floor) for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        """Step every floor; restart the ended ones at once (SB3's same-step autoreset)."""
        if self._actions is None:
            raise RuntimeError("call step_async(actions) before step_wait()")
        actions, self._actions = self._actions, None
        obs, rewards, terminated, truncated, infos = self.native.step(actions)
        dones = terminated | truncated
        step_infos = _split_infos(infos, self.num_envs)
        ended = np.flatnonzero(dones)
        if ended.size:
            new_obs, reset_infos = self.native.reset(options={"reset_mask": dones})
            first_infos = _split_infos(reset_infos, self.num_envs)
            for i in ended.tolist():
                step_infos[i]["terminal_observation"] = obs[i]
                step_infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                self.reset_infos[i] = first_infos[i]
            obs = obs.copy()
            obs[ended] = new_obs[ended]
        return obs, rewards.astype(np.float32), dones, step_infos

    def close(self) -> None:
        """Close the native vector environment."""
        self.native.close()

    # ------------------------------------------------------------- the rest of the API
    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The native environment's ``attr_name``, once for each index asked for."""
        value = getattr(self.native, attr_name)
        return [value] * len(self._indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set ``attr_name`` of the native environment, which every floor shares."""
        self._all_floors(indices, "set_attr")
        setattr(self.native, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        """Call the native environment's method once; its result once for each floor."""
        self._all_floors(indices, "env_method")
        result = getattr(self.native, method_name)(*method_args, **method_kwargs)
        return [result] * self.num_envs

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """False for every floor: the floors are no wrapped Gymnasium environments."""
        return [False] * len(self._indices(indices))

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One ``(H, W, 3)`` frame per floor, in ``render_mode="rgb_array"``."""
        if self.native.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.native.render())

    def _indices(self, indices: Any) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, (int, np.integer)):
            indices = [indices]
        chosen = [int(i) for i in indices] if isinstance(indices, Iterable) else None
        if chosen is None or not all(0 <= i < self.num_envs for i in chosen):
            raise IndexError(f"indices must name floors 0..{self.num_envs - 1}, got {indices!r}")
        return chosen

    def _all_floors(self, indices: Any, what: str) -> None:
        if sorted(set(self._indices(indices))) != list(range(self.num_envs)):
            raise ValueError(
                f"{what} acts on the native vector environment, which every floor shares: "
                f"indices must name all {self.num_envs} floors (or be None), got {indices!r}"
            )


def _split_infos(infos: dict[str, Any], num_envs: int) -> list[dict[str, Any]]:
    """Gymnasium's vector infos (arrays with ``_key`` masks) as one dict per floor."""
    split: list[dict[str, Any]] = [{} for _ in range(num_envs)]
    for key, values in infos.items():
        if key.startswith("_"):
            continue
        mask = infos.get(f"_{key}")
        for i, value in enumerate(np.asarray(values).tolist()):
            if mask is None or mask[i]:
                split[i][key] = value
    return split
