"""The package's planners by name: what each name plans with, and the planner itself.

One table for every caller that takes a planner by name (the fleet policies of
:mod:`warehouse_phys.rl.fleet_planners`, the windows of plans run on ticks in
:mod:`warehouse_phys.execution.windows`, the start-kit entry's planners):

- ``"pibt"``: plain :class:`~warehouse_phys.planners.pibt.PIBT`;
- ``"guided"``: :class:`~warehouse_phys.planners.guidance.GuidedPIBT`, PIBT following
  guide paths priced by the fleet's traffic; its ablations ``"guided-costs"`` (the
  prices alone, a tie-break of PIBT's distances) and ``"guided-paths"`` (shortest guide
  paths);
- for turning robots only (:data:`TURNING_ONLY`): ``"guided-ops"`` and ``"pibt-ops"``,
  planned over operations of :data:`OPERATION_DEPTH` actions with and without guidance,
  and ``"guided-repair"`` and ``"guided-ops-repair"``, whose plans the windowed repair
  (:class:`~warehouse_phys.planners.repair.WindowRepair`) improves each step.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from typing import Any, NamedTuple

from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.guidance_config import GuidanceConfig, default_workers
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.world.grid import WarehouseGrid

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
#: A bound on the cells a repairing planner's later steps may expand in their guide-path
#: searches (``later_max_expanded``) [cells]: about 1.3 s of one core here. It bounds
#: the steps where hundreds of robots are pushed off their paths at once (MR23-I-06's
#: second step: 9.4 million cells, 2.7 s) and leaves the others alone; over 5,000 steps
#: of MR23-I-06 and MR23-I-10 and the first 1,000 of 2024 WAREHOUSE it cost at most
#: 0.8 % of the errands or tasks (the documentation's LoRR page, ``docs/lorr.md``).
LATER_MAX_EXPANDED = 4_000_000
#: The repairing planners' guidance beyond their base's: lanes over the whole floor (over
#: the first 300 steps with turning robots, seed 0, they added 1.0 % to the repair's
#: errands on MR23-I-10 and 5.1 % to its tasks on 2024 WAREHOUSE; not measured on the
#: Kiva floor), and the bound :data:`LATER_MAX_EXPANDED`.
REPAIR_GUIDANCE: dict[str, Any] = {
    "floor_lane_paths": 2,
    "later_max_expanded": LATER_MAX_EXPANDED,
}
#: The repair's settings (:class:`~warehouse_phys.planners.repair.WindowRepair`'s arguments).
REPAIR: dict[str, Any] = {"neighbourhood": 8, "iterations": 2000}
#: Fields a repairing planner's ``guidance`` may also set: the repair's.
REPAIR_FIELDS = {"neighbourhood": "neighbourhood", "iterations": "iterations",
                 "repair_time_limit": "time_limit"}  # fmt: skip
#: Every planner's name.
PLANNERS = ("pibt", *PLANNER_GUIDANCE, *PLANNER_OPERATIONS, *PLANNER_REPAIRS)
#: The names of :data:`PLANNERS` that plan turning robots only (``moves="rotate"``).
TURNING_ONLY = frozenset((*PLANNER_OPERATIONS, *PLANNER_REPAIRS))


class PlannerSetup(NamedTuple):
    """What a planner's name stands for: its guidance (None: plain PIBT), its operations'
    actions (0: one action a step) and its repair's arguments (None: no repair)."""

    config: GuidanceConfig | None
    operations: int
    repair: dict[str, Any] | None


def guidance_from_json(text: str) -> dict[str, Any]:
    """The guided planner's fields in ``text``, a JSON object such as ``{"reroute": 32}``
    (the command lines' ``--guidance``, the entry's ``WAREHOUSE_PHYS_GUIDANCE``); the
    planner checks the fields themselves (:func:`split_guidance`).

    Raises:
        ValueError: for text that is not a JSON object.
    """
    try:
        fields = json.loads(text)
    except ValueError:
        fields = None
    if not isinstance(fields, dict):
        raise ValueError("not a JSON object of the planner's fields, such as "
                         '{"reroute": 32}')  # fmt: skip
    return fields


def split_guidance(name: str, guidance: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``guidance`` for the guided planner ``name`` split in two: the fields of its
    :class:`~warehouse_phys.planners.guidance_config.GuidanceConfig`, and (a repairing
    planner's, :data:`PLANNER_REPAIRS`) its repair's, as
    :class:`~warehouse_phys.planners.repair.WindowRepair`'s arguments
    (:data:`REPAIR_FIELDS`). The values are checked where they are used.

    Raises:
        TypeError: naming a field that neither the guidance nor the repair has.
    """
    known = [field.name for field in dataclasses.fields(GuidanceConfig)]
    known += list(REPAIR_FIELDS) if name in PLANNER_REPAIRS else []
    unknown = sorted(set(guidance) - set(known))
    if unknown:
        raise TypeError(f"planner {name!r} has no field {unknown[0]!r}; its fields: "
                        f"{', '.join(known)}")  # fmt: skip
    fields = {key: value for key, value in guidance.items() if key not in REPAIR_FIELDS}
    repair = {REPAIR_FIELDS[key]: value for key, value in guidance.items()
              if key in REPAIR_FIELDS}  # fmt: skip
    return fields, repair


def planner_setup(name: str, **guidance: Any) -> PlannerSetup:
    """The setup of the planner ``name`` (one of :data:`PLANNERS`); ``guidance`` overrides
    fields of a guided planner's :class:`~warehouse_phys.planners.guidance.GuidanceConfig`
    (``time_limit=0.5``, say), and of a repairing planner's repair (:data:`REPAIR_FIELDS`:
    ``neighbourhood``, ``iterations``, ``repair_time_limit``).

    Raises:
        ValueError: for an unknown name, or guidance given to plain PIBT.
        TypeError: naming a field that neither the guidance nor (for a repairing
            planner) the repair has.
    """
    if name == "pibt":
        if guidance:
            raise ValueError(f"plain PIBT takes no guidance, got {sorted(guidance)}")
        return PlannerSetup(None, 0, None)
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; known: {', '.join(PLANNERS)}")
    fields, repair_fields = split_guidance(name, guidance)
    repair = dict(REPAIR) | repair_fields if name in PLANNER_REPAIRS else None
    base = PLANNER_REPAIRS.get(name, name)
    config = PLANNER_GUIDANCE.get(base) or PLANNER_OPERATIONS[base]
    if repair is not None:
        config = dataclasses.replace(config, **REPAIR_GUIDANCE)
    # The tables above were made at import; the cores this process may run on are
    # counted now (a Ray worker, say, may be given fewer since).
    config = dataclasses.replace(config, **{"workers": default_workers(), **fields})
    depth = OPERATION_DEPTH if base in PLANNER_OPERATIONS else 0
    return PlannerSetup(config, depth, repair)


def named_planner(
    name: str,
    grid: WarehouseGrid,
    *,
    moves: str = "grid",
    seed: int = 0,
    distances: DistanceMaps | None = None,
    corner_follows: bool = True,
    **guidance: Any,
) -> PIBT | GuidedPIBT:
    """The planner called ``name`` (one of :data:`PLANNERS`) for a fleet on ``grid``
    moving by ``moves``, seeded; ``guidance`` as :func:`planner_setup` takes it.

    Raises:
        ValueError: as :func:`planner_setup`, and for a name of :data:`TURNING_ONLY` with
            ``moves`` other than ``"rotate"``.
    """
    setup = planner_setup(name, **guidance)
    if name in TURNING_ONLY and moves != "rotate":
        raise ValueError(f"planner {name!r} plans turning robots only (moves='rotate'), got "
                         f"moves={moves!r}")  # fmt: skip
    if setup.config is None:
        return PIBT(grid, distances=distances, corner_follows=corner_follows, seed=seed,
                    moves=moves)  # fmt: skip
    repair = None if setup.repair is None else WindowRepair(seed=seed, **setup.repair)
    return GuidedPIBT(grid, distances=distances, corner_follows=corner_follows, seed=seed,
                      moves=moves, config=setup.config, operations=setup.operations,
                      repair=repair)  # fmt: skip
