"""The planners by name: every name makes its planner, with its operations and repair, for
the robots it plans; other names and robots are refused by name."""

import numpy as np
import pytest

from warehouse_phys.planners import named
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.named import (
    LATER_MAX_EXPANDED,
    OPERATION_DEPTH,
    PLANNER_REPAIRS,
    PLANNERS,
    TURNING_ONLY,
    named_planner,
    planner_setup,
)
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.grid import WarehouseGrid

FLOOR = WarehouseGrid.from_layout(["....", ".#..", "...."])


@pytest.mark.parametrize("name", PLANNERS)
def test_every_name_makes_its_planner(name):
    planner = named_planner(name, FLOOR, moves="rotate", seed=3)
    if name == "pibt":
        assert type(planner) is PIBT
        return
    assert isinstance(planner, GuidedPIBT)
    assert (planner.operations is not None) == name.endswith(("-ops", "-ops-repair"))
    assert (planner.repair is not None) == name.endswith("-repair")
    if planner.operations is not None:
        assert planner.operations.depth == OPERATION_DEPTH


def test_turning_only_planners_refuse_four_direction_robots():
    for name in TURNING_ONLY:
        with pytest.raises(ValueError, match=f"planner '{name}' plans turning robots only"):
            named_planner(name, FLOOR, moves="grid")
    assert isinstance(named_planner("guided", FLOOR, moves="grid"), GuidedPIBT)


def test_guidance_and_repair_settings_reach_the_planner():
    setup = planner_setup("guided-ops-repair", time_limit=0.5, neighbourhood=4)
    assert setup.config.time_limit == 0.5
    assert setup.repair["neighbourhood"] == 4
    planner = named_planner("guided-repair", FLOOR, moves="rotate", iterations=7)
    assert planner.repair.iterations == 7


def test_a_planner_counts_the_cores_when_it_is_made_not_when_the_table_was(monkeypatch):
    """The planners' threads (``workers``) are the cores the process may run on when the
    planner is made, unless given: a process given fewer cores after the tables were made
    (a Ray worker, say) gets as many threads as it has cores."""
    monkeypatch.setattr(named, "default_workers", lambda: 3)
    for name in PLANNERS[1:]:
        assert planner_setup(name).config.workers == 3
        assert planner_setup(name, workers=1).config.workers == 1
    assert named_planner("guided", FLOOR).guidance.config.workers == 3


def test_a_repairing_planners_later_steps_stop_at_its_bound_on_the_cells_searched(monkeypatch):
    """The repairing planners bound the cells their later steps' guide-path searches
    expand (:data:`~warehouse_phys.planners.named.LATER_MAX_EXPANDED`); the others do not,
    and ``later_max_expanded=None`` lifts it. With a bound of one cell a repairing
    planner's second step searches one robot's guide path, where every robot needs one."""
    for name in PLANNER_REPAIRS:
        assert planner_setup(name).config.later_max_expanded == LATER_MAX_EXPANDED
        assert planner_setup(name, later_max_expanded=None).config.later_max_expanded is None
    assert planner_setup("guided-ops").config.later_max_expanded is None
    monkeypatch.setitem(named.REPAIR_GUIDANCE, "later_max_expanded", 1)
    grid = WarehouseGrid(8, 8)
    cells = np.array([(row, col) for row in range(4) for col in (0, 2, 4, 6)])  # 16 robots
    headings = np.zeros(16, dtype=np.int64)
    searches = []
    for name in ("guided-ops-repair", "guided-ops"):
        planner = named_planner(name, grid, moves="rotate")
        for shift in ((4, 0), (4, 1)):  # every robot a new goal at the second step
            planner.plan(cells, cells + shift, headings=headings)
            searches.append(planner.guidance.searches)
    assert searches == [16, 1, 16, 16]


def test_unknown_names_and_guidance_for_plain_pibt_are_refused():
    with pytest.raises(ValueError, match="unknown planner 'lacam'"):
        named_planner("lacam", FLOOR)
    with pytest.raises(ValueError, match="plain PIBT takes no guidance"):
        planner_setup("pibt", time_limit=1.0)


def test_a_field_the_planner_lacks_is_refused_naming_its_fields():
    with pytest.raises(TypeError, match="planner 'guided' has no field 'nope'; its fields: "
                       "vertex_weight, contraflow_weight"):  # fmt: skip
        planner_setup("guided", nope=1)
    # The repair's fields belong to the repairing planners alone.
    with pytest.raises(TypeError, match="planner 'guided' has no field 'iterations'"):
        planner_setup("guided", iterations=7)
    assert planner_setup("guided-repair", iterations=7).repair["iterations"] == 7
