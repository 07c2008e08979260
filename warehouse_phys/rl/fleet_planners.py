"""Fleet policies (``FleetPolicy``) of the planners, by name (the names and what each plans
with: :mod:`warehouse_phys.planners.named`).

:func:`pibt_policy` plans with :class:`~warehouse_phys.planners.pibt.PIBT`.
:func:`guided_pibt_policy` plans with :class:`~warehouse_phys.planners.guidance.GuidedPIBT`:
PIBT following guide paths priced by the fleet's traffic. :func:`planner_policy` gives a
policy by name (``"pibt"``, ``"guided"``, the guidance's ablations ``"guided-costs"``
and ``"guided-paths"``, and for turning robots ``"guided-ops"`` and ``"pibt-ops"``, planned
over multi-action operations with and without guidance, and ``"guided-repair"`` and
``"guided-ops-repair"``, whose plans a windowed repair improves each step), for benchmarks
and command lines.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.planners import named
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.guidance_config import GuidanceConfig
from warehouse_phys.planners.named import planner_setup
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.rl.fleet_evaluation import FleetPolicy

#: The planners' names and settings, kept in :mod:`warehouse_phys.planners.named` and
#: served here too, where the fleet policies first took them.
PLANNER_GUIDANCE = named.PLANNER_GUIDANCE
PLANNER_OPERATIONS = named.PLANNER_OPERATIONS
OPERATION_DEPTH = named.OPERATION_DEPTH
PLANNER_REPAIRS = named.PLANNER_REPAIRS
REPAIR_GUIDANCE = named.REPAIR_GUIDANCE
REPAIR = named.REPAIR
REPAIR_FIELDS = named.REPAIR_FIELDS
PLANNERS = named.PLANNERS
TURNING_ONLY = named.TURNING_ONLY


class PIBTPolicy:
    """A fleet policy (``FleetPolicy``) that plans with
    :class:`~warehouse_phys.planners.pibt.PIBT`; :func:`pibt_policy` makes one.
    ``planner`` is the planner of the episode under way, ``None`` before the first call:
    a new one when the environment resets (``env.steps`` back at 0) or another
    environment calls it. A plain object, so that a run's state pickles (the policy with
    its environment)."""

    def __init__(self, seed: int = 0) -> None:
        self.seed = seed
        self.planner: PIBT | GuidedPIBT | None = None
        self._env: WarehouseFleetEnv | None = None
        self._index: dict[str, int] = {}

    def __call__(
        self,
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        """Every live robot's action for the next step, from the fleet's public state."""
        if self._env is not env or env.steps == 0 or self.planner is None:
            self._env = env
            self.planner = self._new_planner(env)
            self._index = {agent: i for i, agent in enumerate(env.possible_agents)}
        actions = self.planner.plan(
            env.robot_cells,
            env.package_cells,
            ~env.parked & env.on_floor,
            env.on_floor,
            headings=getattr(env, "robot_headings", None),
        ).tolist()
        return {agent: actions[self._index[agent]] for agent in env.agents}

    def _new_planner(self, env: WarehouseFleetEnv) -> PIBT | GuidedPIBT:
        """The planner of a new episode on ``env``."""
        return PIBT(env.grid, distances=env.distances, corner_follows=env.corner_follows,
                    seed=self.seed, moves=getattr(env, "moves", "grid"))  # fmt: skip


def pibt_policy(seed: int = 0) -> FleetPolicy:
    """A fleet policy (``FleetPolicy``) that plans with :class:`~warehouse_phys.planners.pibt.PIBT`:
    stateful across the steps of an episode, started afresh when the environment resets
    (``env.steps`` back at 0) or another environment calls it. It reads the fleet's public
    state only: ``grid``, ``robot_cells``, ``package_cells``, ``parked``, ``on_floor``,
    ``steps``, ``corner_follows``, ``distances``, and for turning robots ``moves`` and
    ``robot_headings`` (a :class:`PIBTPolicy`)."""
    return PIBTPolicy(seed)


class GuidedPIBTPolicy(PIBTPolicy):
    """A fleet policy (``FleetPolicy``) that plans with
    :class:`~warehouse_phys.planners.guidance.GuidedPIBT`; :func:`guided_pibt_policy` makes
    one. ``planner`` is the planner of the episode under way (its ``guidance`` counts the
    last step's searches and unguided robots), ``None`` before the first call."""

    def __init__(
        self,
        seed: int = 0,
        config: GuidanceConfig | None = None,
        operations: int = 0,
        repair: dict[str, Any] | None = None,
    ) -> None:
        super().__init__(seed)
        self.planner: GuidedPIBT | None = None
        self.config = config
        self.operations = operations
        self.repair = repair

    def _new_planner(self, env: WarehouseFleetEnv) -> GuidedPIBT:
        return GuidedPIBT(
            env.grid,
            distances=env.distances,
            corner_follows=env.corner_follows,
            seed=self.seed,
            moves=getattr(env, "moves", "grid"),
            config=self.config,
            operations=self.operations,
            repair=None if self.repair is None else WindowRepair(seed=self.seed, **self.repair),
        )


def guided_pibt_policy(
    seed: int = 0,
    config: GuidanceConfig | None = None,
    operations: int = 0,
    repair: dict[str, Any] | None = None,
) -> FleetPolicy:
    """A fleet policy that plans with :class:`~warehouse_phys.planners.guidance.GuidedPIBT`
    (``config``: the guidance, :class:`~warehouse_phys.planners.guidance.GuidanceConfig`'s
    defaults unless given; ``operations``: its operations' actions, turning robots only,
    0 for one-step PIBT): stateful across the steps of an episode, started afresh when
    the environment resets (``env.steps`` back at 0) or another environment calls it, and
    deterministic for a seed (while the guidance's ``time_limit`` is not reached);
    ``repair``: the arguments of a :class:`~warehouse_phys.planners.repair.WindowRepair`
    that improves each step's plan (turning robots only; None: none). It reads the
    fleet's public state only, as :func:`pibt_policy` does (a :class:`GuidedPIBTPolicy`)."""
    return GuidedPIBTPolicy(seed, config, operations, repair)


def planner_policy(name: str, seed: int = 0, **guidance: Any) -> FleetPolicy:
    """The policy of the planner ``name`` (one of :data:`PLANNERS`), seeded; ``guidance``
    overrides fields of a guided planner's :class:`~warehouse_phys.planners.guidance.GuidanceConfig`
    (``time_limit=0.5``, say), and of a repairing planner's repair (:data:`REPAIR_FIELDS`:
    ``neighbourhood``, ``iterations``, ``repair_time_limit``).

    Raises:
        ValueError: for an unknown name, or guidance given to plain PIBT.
    """
    setup = planner_setup(name, **guidance)
    if setup.config is None:
        return pibt_policy(seed=seed)
    return guided_pibt_policy(seed=seed, config=setup.config, operations=setup.operations,
                              repair=setup.repair)  # fmt: skip
