"""Fleet policies (``FleetPolicy``) of the planners, by name.

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

import dataclasses
from typing import Any

import numpy as np

from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.guidance_config import GuidanceConfig
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.rl.fleet_evaluation import FleetPolicy

#: The guidance of each named planner: following congestion-priced guide paths
#: (``guided``), the prices alone as a tie-break of PIBT's distances (``guided-costs``),
#: following shortest guide paths (``guided-paths``).
PLANNER_GUIDANCE: dict[str, GuidanceConfig] = {
    "guided": GuidanceConfig(),
    "guided-costs": GuidanceConfig(follow=False),
    "guided-paths": GuidanceConfig(vertex_weight=0.0, contraflow_weight=0.0),
}
#: Planners over multi-action operations of 3 actions (turning robots only:
#: :class:`~warehouse_phys.planners.operations.OperationPIBT`), by name, and their guidance:
#: the ``guided`` planner's (``guided-ops``), or none, distances alone (``pibt-ops``: no
#: guide path is searched).
PLANNER_OPERATIONS: dict[str, GuidanceConfig] = {
    "guided-ops": GuidanceConfig(),
    "pibt-ops": GuidanceConfig(max_searches=0),
}
#: Actions in an operation of the planners of :data:`PLANNER_OPERATIONS`.
OPERATION_DEPTH = 3
#: Planners whose plans a windowed repair improves each step (turning robots only:
#: :class:`~warehouse_phys.planners.repair.WindowRepair`), by name: the planner they
#: repair, whose guidance they take with :data:`REPAIR_GUIDANCE` on top.
PLANNER_REPAIRS: dict[str, str] = {"guided-repair": "guided", "guided-ops-repair": "guided-ops"}
#: The repairing planners' guidance beyond their base's: lanes over the whole floor. Over
#: the first 300 steps with turning robots (seed 0) they added 1.0 % to the repair's
#: errands on MR23-I-10 and 5.1 % to its tasks on 2024 WAREHOUSE (the
#: documentation's LoRR page, ``docs/lorr.md``); not measured on the Kiva floor.
REPAIR_GUIDANCE: dict[str, Any] = {"floor_lane_paths": 2}
#: The repair's settings (:class:`~warehouse_phys.planners.repair.WindowRepair`'s arguments).
REPAIR: dict[str, Any] = {"neighbourhood": 8, "iterations": 2000}
#: Fields a repairing planner's ``guidance`` may also set: the repair's.
REPAIR_FIELDS = {"neighbourhood": "neighbourhood", "iterations": "iterations",
                 "repair_time_limit": "time_limit"}  # fmt: skip
#: Every name :func:`planner_policy` knows.
PLANNERS = ("pibt", *PLANNER_GUIDANCE, *PLANNER_OPERATIONS, *PLANNER_REPAIRS)
#: The names of :data:`PLANNERS` that plan turning robots only (``moves="rotate"``).
TURNING_ONLY = frozenset((*PLANNER_OPERATIONS, *PLANNER_REPAIRS))


def pibt_policy(seed: int = 0) -> FleetPolicy:
    """A fleet policy (``FleetPolicy``) that plans with :class:`~warehouse_phys.planners.pibt.PIBT`:
    stateful across the steps of an episode, started afresh when the environment resets
    (``env.steps`` back at 0) or another environment calls it. It reads the fleet's public
    state only: ``grid``, ``robot_cells``, ``package_cells``, ``parked``, ``on_floor``,
    ``steps``, ``corner_follows``, ``distances``, and for turning robots ``moves`` and
    ``robot_headings``."""
    state: dict[str, Any] = {"env": None, "planner": None, "index": {}}

    def policy(
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        if state["env"] is not env or env.steps == 0:
            state["env"] = env
            state["planner"] = PIBT(env.grid, distances=env.distances,
                                    corner_follows=env.corner_follows, seed=seed,
                                    moves=getattr(env, "moves", "grid"))  # fmt: skip
            state["index"] = {agent: i for i, agent in enumerate(env.possible_agents)}
        planner: PIBT = state["planner"]
        actions = planner.plan(
            env.robot_cells,
            env.package_cells,
            ~env.parked & env.on_floor,
            env.on_floor,
            headings=getattr(env, "robot_headings", None),
        ).tolist()
        index = state["index"]
        return {agent: actions[index[agent]] for agent in env.agents}

    return policy


class GuidedPIBTPolicy:
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
        self.seed = seed
        self.config = config
        self.operations = operations
        self.repair = repair
        self.planner: GuidedPIBT | None = None
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
            self.planner = GuidedPIBT(
                env.grid,
                distances=env.distances,
                corner_follows=env.corner_follows,
                seed=self.seed,
                moves=getattr(env, "moves", "grid"),
                config=self.config,
                operations=self.operations,
                repair=None if self.repair is None else WindowRepair(seed=self.seed, **self.repair),
            )
            self._index = {agent: i for i, agent in enumerate(env.possible_agents)}
        actions = self.planner.plan(
            env.robot_cells,
            env.package_cells,
            ~env.parked & env.on_floor,
            env.on_floor,
            headings=getattr(env, "robot_headings", None),
        ).tolist()
        return {agent: actions[self._index[agent]] for agent in env.agents}


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
    if name == "pibt":
        if guidance:
            raise ValueError(f"plain PIBT takes no guidance, got {sorted(guidance)}")
        return pibt_policy(seed=seed)
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; known: {list(PLANNERS)}")
    repair = dict(REPAIR) if name in PLANNER_REPAIRS else None
    if repair is not None:
        repair |= {REPAIR_FIELDS[key]: guidance.pop(key) for key in list(guidance)
                   if key in REPAIR_FIELDS}  # fmt: skip
    base = PLANNER_REPAIRS.get(name, name)
    config = PLANNER_GUIDANCE.get(base) or PLANNER_OPERATIONS[base]
    if repair is not None:
        config = dataclasses.replace(config, **REPAIR_GUIDANCE)
    if guidance:
        config = dataclasses.replace(config, **guidance)
    depth = OPERATION_DEPTH if base in PLANNER_OPERATIONS else 0
    return guided_pibt_policy(seed=seed, config=config, operations=depth, repair=repair)
