"""League of Robot Runners 2026 instances made from a floor: robots on random starts, tasks of
random errands, ticks and delays as the competition's 2026 examples have them.

:func:`make_instance` draws ``robots`` distinct starts among the floor's reachable cells
and ``tasks`` tasks of ``stops`` errands each (every errand a reachable cell, two
consecutive errands of a task never the same cell), all from one
:class:`numpy.random.Generator` seeded with ``seed``: the same arguments give the same
instance. It is a :class:`~warehouse_phys.lorr.instances.LorrInstance` of version
``"2026 LoRR"`` (``agentCounter``, ``agentSize``, ``delayConfig``), which
:func:`~warehouse_phys.lorr.instances.write_instance` writes as the kit reads it (map,
agents and tasks files beside the JSON). The start kit ships no generator of its own for
2026 instances; the competition's examples (``random-example_400``, ``maze-example_40``)
are 2 errands a task and 1.5 open tasks a robot, as the defaults here.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.execution.swept_squares import checked_size
from warehouse_phys.execution.ticks import check_ticks_per_move, check_whole
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.world.grid import WarehouseGrid

#: The 2026 examples' delays (random-example_400's ``delayConfig``), seed aside.
EXAMPLE_DELAYS = DelayConfig(seed=0, min_delay=1, max_delay=4, event_model="bernoulli",
                             p_delay=0.01, duration_model="uniform", gauss_mean_ratio=0.5,
                             gauss_std_ratio=0.22)  # fmt: skip


def make_instance(
    grid: WarehouseGrid,
    robots: int,
    tasks: int,
    *,
    seed: int = 0,
    name: str = "generated",
    stops: int = 2,
    num_tasks_reveal: float = 1.5,
    agent_counter: int = 3,
    agent_size: float = 1.0,
    delay: DelayConfig | None = EXAMPLE_DELAYS,
) -> LorrInstance:
    """A 2026 instance on ``grid`` (see the module).

    Raises:
        ValueError, TypeError: naming the argument, for fewer reachable cells than
            ``robots`` (or than two, for tasks of several errands), a count out of range,
            or a bad ``agent_counter``, ``agent_size`` or ``delay``.
    """
    robots = check_whole("robots", robots, 1, 1_000_000)
    tasks = check_whole("tasks", tasks, 1, 10_000_000)
    stops = check_whole("stops", stops, 1, 100)
    seed = check_whole("seed", seed, 0, 2**63 - 1)
    counter = check_ticks_per_move(agent_counter, "agent_counter")
    size = checked_size(agent_size)
    if delay is not None and not isinstance(delay, DelayConfig):
        raise TypeError(f"delay must be a DelayConfig or None, got {type(delay).__name__}")
    room = np.flatnonzero(grid.reachable_mask.reshape(-1))
    if len(room) < robots or (stops > 1 and len(room) < 2):
        raise ValueError(f"robots: {robots:,} robots need as many reachable cells; the floor "
                         f"has {len(room):,}")  # fmt: skip
    rng = np.random.default_rng(seed)
    starts = rng.choice(room, size=robots, replace=False)
    errands = rng.choice(room, size=(tasks, stops))
    for k in range(1, stops):  # no errand where the last one was
        same = errands[:, k] == errands[:, k - 1]
        while same.any():
            errands[same, k] = rng.choice(room, size=int(same.sum()))
            same = errands[:, k] == errands[:, k - 1]
    return LorrInstance(
        name=name, grid=grid, starts=starts, task_offsets=np.arange(tasks + 1) * stops,
        task_stops=errands.reshape(-1), num_tasks_reveal=float(num_tasks_reveal),
        assignment="scheduler", version="2026 LoRR", agent_counter=counter,
        agent_size=size, delay=delay,
    )  # fmt: skip
