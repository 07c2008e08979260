"""How well a fleet's policy delivers, and the baseline policies it is compared with.

The multi-robot planning field's measures, over fixed seeds:

- one-shot (each robot one package, ``on_delivery="park"`` or ``"leave"``):
  :func:`evaluate_fleet` counts packages delivered, the **sum of costs** (each
  robot's steps until it delivered, an undelivered robot counted at the time
  limit) against the sum of shortest paths, the **makespan** (the step of the
  last delivery, or the time limit), refused moves, waits, episodes stuck at the
  time limit and packages **walled off** by parked robots;
- lifelong (``on_delivery="new_package"``): :func:`evaluate_fleet` (or
  :func:`evaluate_throughput`) gives the **throughput**, deliveries per step, the mean
  over the seeds, with refused moves and waits.

:func:`compare_policies` lays several evaluations side by side and says plainly
where a policy does worse than the shortest-path baseline or than random.
:func:`shortest_path_policy` is that baseline: each robot takes a move along a
shortest path to its package and waits when that cell is taken;
:func:`random_fleet_policy` acts at random.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.world.floor_regions import label_regions
from warehouse_phys.world.headings import TurnAction, facing_move, turn_towards
from warehouse_phys.world.traffic import WAIT, neighbour_table

#: A fleet policy: the environment, every live robot's observation and last info -> actions.
FleetPolicy = Callable[
    [WarehouseFleetEnv, dict[str, np.ndarray], dict[str, dict[str, Any]]], dict[str, int]
]


def shortest_path_policy(
    env: WarehouseFleetEnv,
    observations: dict[str, np.ndarray],
    infos: dict[str, dict[str, Any]],
) -> dict[str, int]:
    """Each robot moves along a shortest path to its package (the first such move in
    action order whose cell no robot on the floor stands on) and waits when every such
    cell is taken; a turning robot drives forward if it faces that cell, else turns
    towards it. Array operations over the live robots, with the fleet's distance maps."""
    agents = list(observations)
    if not agents:
        return {}
    cols = env.grid.cols
    robots = np.fromiter((int(a.rsplit("_", 1)[1]) for a in agents), np.int64, len(agents))
    cells, packages = env.robot_cells, env.package_cells
    here = cells[robots, 0] * cols + cells[robots, 1]
    goal = packages[robots, 0] * cols + packages[robots, 1]
    taken = np.zeros(env.grid.rows * cols, dtype=bool)
    on_floor = cells[env.on_floor]
    taken[on_floor[:, 0] * cols + on_floor[:, 1]] = True
    moves = neighbour_table(env.grid)[here, :WAIT]  # (n, 4)
    distance = env.distances.lookup(np.concatenate([here, moves.ravel()]),
                                    np.concatenate([goal, np.repeat(goal, WAIT)]))  # fmt: skip
    now, after = distance[: len(here)], distance[len(here) :].reshape(-1, WAIT)
    good = (after < now[:, None]) & ~taken[moves]
    actions = np.where(good.any(axis=1), good.argmax(axis=1), WAIT)
    if env.robot_headings is not None:  # turning robots: face the move, then make it
        headings = env.robot_headings[robots]
        wanted = facing_move(actions, headings)
        actions = turn_towards(headings, wanted)
        actions[(wanted == headings) & good.any(axis=1)] = TurnAction.FORWARD
    return dict(zip(agents, actions.tolist(), strict=True))


def random_fleet_policy(seed: int) -> FleetPolicy:
    """Every robot takes a uniformly random action of its action space (the five of the
    four-direction fleet, the four of turning robots), from a generator of ``seed``."""
    rng = np.random.default_rng([seed, 3])

    def policy(
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        if not observations:
            return {}
        count = int(env.action_space(next(iter(observations))).n)
        return {agent: int(rng.integers(count)) for agent in observations}

    return policy


@dataclass(frozen=True)
class FleetEvaluation:
    """How a policy did over fixed seeds, each robot delivering one package."""

    episodes: int
    robots: int
    #: Packages delivered, of ``episodes * robots``.
    delivered: int
    #: Steps each robot took to its package, summed over the robots that delivered.
    robot_steps: int
    #: The same robots' shortest paths at the start, summed: the steps without traffic.
    shortest_steps: int
    #: Moves that traffic turned into waits.
    refused: int
    #: Episodes that the time limit ended with a package undelivered.
    deadlocks: int
    #: Sum of costs: every robot's steps until it delivered, an undelivered robot
    #: counted at the step its episode ended, summed over robots and episodes.
    sum_of_costs: int = 0
    #: Every robot's shortest path at the start, summed: the sum of costs without traffic.
    all_shortest_steps: int = 0
    #: The step of each episode's last delivery (its last step when one is missing), summed.
    makespan_total: int = 0
    #: WAITs asked for by robots that had not delivered.
    waits: int = 0
    #: Undelivered packages that parked robots cut off from their robot at the end.
    walled_off: int = 0

    @property
    def delay(self) -> int:
        """Steps that traffic (and detours) cost the delivering robots."""
        return self.robot_steps - self.shortest_steps

    @property
    def makespan(self) -> float:
        """Mean makespan over the episodes [steps]."""
        return self.makespan_total / self.episodes if self.episodes else 0.0

    @property
    def undelivered(self) -> int:
        return self.episodes * self.robots - self.delivered

    def summary(self) -> str:
        walled = f" ({self.walled_off} walled off by parked robots)" if self.walled_off else ""
        return (
            f"{self.delivered}/{self.episodes * self.robots} packages delivered{walled}; "
            f"sum of costs {self.sum_of_costs} against {self.all_shortest_steps} on shortest "
            f"paths, mean makespan {self.makespan:.1f}; delivering robots {self.robot_steps} "
            f"robot-steps against {self.shortest_steps} (delay {self.delay}); "
            f"{self.refused} moves refused by traffic, {self.deadlocks} episode(s) stuck at "
            "the time limit"
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "episodes": self.episodes,
            "robots": self.robots,
            "delivered": self.delivered,
            "undelivered": self.undelivered,
            "walled_off": self.walled_off,
            "sum_of_costs": self.sum_of_costs,
            "all_shortest_steps": self.all_shortest_steps,
            "makespan": self.makespan,
            "robot_steps": self.robot_steps,
            "shortest_steps": self.shortest_steps,
            "delay": self.delay,
            "refused": self.refused,
            "waits": self.waits,
            "deadlocks": self.deadlocks,
        }


def evaluate_fleet(
    env: WarehouseFleetEnv,
    policy: FleetPolicy,
    *,
    seeds: range = range(20),
    steps: int | None = None,
) -> FleetEvaluation | ThroughputEvaluation:
    """Play ``policy`` on ``env`` once per seed and measure it as the field does.

    One-shot (``on_delivery`` ``"park"`` or ``"leave"``): each seed's episode runs until
    every robot delivered or the time limit; a :class:`FleetEvaluation`. Lifelong
    (``"new_package"``): each seed runs ``steps`` joint steps (default
    ``env.max_cycles``); a :class:`ThroughputEvaluation`, as :func:`evaluate_throughput`.

    The work of a step is array operations over the fleet (``env.robot_cells``,
    ``env.deliveries``, ...) plus one pass over the policy's actions and the infos.

    Raises:
        ValueError: for ``steps`` on a one-shot fleet, which ends when its robots do.
    """
    if env.lifelong:
        return evaluate_throughput(
            env, policy, steps=env.max_cycles if steps is None else steps, seeds=seeds
        )
    if steps is not None:
        raise ValueError(
            "steps is for lifelong fleets; a one-shot fleet runs until its robots delivered "
            "or max_cycles"
        )
    totals = dict.fromkeys(("delivered", "robot_steps", "shortest_steps", "refused",
                            "deadlocks", "sum_of_costs", "all_shortest_steps",
                            "makespan_total", "waits", "walled_off"), 0)  # fmt: skip
    cols = env.grid.cols
    for seed in seeds:
        observations, infos = env.reset(seed=seed)
        cells, packages = env.robot_cells, env.package_cells
        optimal = env.distances.lookup(
            cells[:, 0] * cols + cells[:, 1], packages[:, 0] * cols + packages[:, 1]
        ).astype(np.int64)
        delivered_at = np.zeros(env.num_robots, dtype=np.int64)
        step = 0
        while env.agents:
            actions = policy(env, observations, infos)
            totals["waits"] += int(np.count_nonzero(np.fromiter(actions.values(), int) == WAIT))
            observations, _, _, _, infos = env.step(actions)
            step += 1
            totals["refused"] += sum(info["refused"] for info in infos.values())
            delivered_at[(env.deliveries > 0) & (delivered_at == 0)] = step
            if len(observations) != len(env.agents):
                observations = {agent: observations[agent] for agent in env.agents}
        done = delivered_at > 0
        totals["delivered"] += int(done.sum())
        totals["robot_steps"] += int(delivered_at[done].sum())
        totals["shortest_steps"] += int(optimal[done].sum())
        totals["sum_of_costs"] += int(np.where(done, delivered_at, step).sum())
        totals["all_shortest_steps"] += int(optimal.sum())
        totals["makespan_total"] += step if not done.all() else int(delivered_at.max())
        if not done.all():
            totals["deadlocks"] += 1
            totals["walled_off"] += walled_off_packages(env)
    return FleetEvaluation(episodes=len(seeds), robots=env.num_robots, **totals)


def walled_off_packages(env: WarehouseFleetEnv) -> int:
    """Robots on the floor, not parked, whose package no path reaches round the parked
    robots: no policy can deliver them any more."""
    free = env.grid.free_mask.copy()
    parked = env.robot_cells[env.parked]
    free[parked[:, 0], parked[:, 1]] = False
    regions, _ = label_regions(free)  # 4-connected regions of the floor left free
    waiting = env.on_floor & ~env.parked
    cells, packages = env.robot_cells[waiting], env.package_cells[waiting]
    return int((regions[cells[:, 0], cells[:, 1]] != regions[packages[:, 0], packages[:, 1]]).sum())


@dataclass(frozen=True)
class ThroughputEvaluation:
    """How a policy did in lifelong runs (``on_delivery="new_package"``) over fixed seeds."""

    robots: int
    steps: int
    #: Deliveries in each seed's run.
    deliveries: tuple[int, ...]
    #: Moves that traffic turned into waits, over every run.
    refused: int
    #: WAITs asked for, over every run.
    waits: int

    @property
    def throughput(self) -> float:
        """Deliveries per step, the mean over the seeds."""
        return float(np.mean(self.deliveries)) / self.steps if self.deliveries else 0.0

    def summary(self) -> str:
        return (
            f"throughput {self.throughput:.2f} deliveries/step ({self.robots} robots, "
            f"{self.steps} steps, {len(self.deliveries)} seed(s)); {self.refused} moves "
            f"refused by traffic, {self.waits} waits"
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "robots": self.robots,
            "steps": self.steps,
            "throughput": self.throughput,
            "deliveries": list(self.deliveries),
            "refused": self.refused,
            "waits": self.waits,
        }


def evaluate_throughput(
    env: WarehouseFleetEnv, policy: FleetPolicy, *, steps: int, seeds: range = range(5)
) -> ThroughputEvaluation:
    """Play ``policy`` on the lifelong ``env`` for ``steps`` joint steps once per seed
    (``env.max_cycles`` must allow them)."""
    if not env.lifelong:
        raise ValueError("evaluate_throughput needs a lifelong fleet (on_delivery='new_package')")
    if env.max_cycles < steps:
        raise ValueError(f"the fleet's max_cycles ({env.max_cycles}) is below steps={steps}")
    deliveries, refused, waits = [], 0, 0
    for seed in seeds:
        observations, infos = env.reset(seed=seed)
        for _ in range(steps):
            actions = policy(env, observations, infos)
            waits += sum(1 for a in actions.values() if a == WAIT)
            observations, _, _, _, infos = env.step(actions)
            refused += sum(info["refused"] for info in infos.values())
        deliveries.append(int(env.deliveries.sum()))
    return ThroughputEvaluation(env.num_robots, steps, tuple(deliveries), refused, waits)


class Measured(Protocol):
    """What :func:`compare_policies` needs of a lifelong measure besides the two
    evaluations (a :class:`~warehouse_phys.apps.simulate.Simulation`, say)."""

    @property
    def throughput(self) -> float: ...

    def summary(self) -> str: ...


def _score(evaluation: FleetEvaluation | ThroughputEvaluation | Measured) -> float:
    """Packages delivered one-shot, deliveries per step otherwise: higher is better."""
    if isinstance(evaluation, FleetEvaluation):
        return evaluation.delivered
    return evaluation.throughput


def worse_policies(
    evaluations: dict[str, FleetEvaluation | ThroughputEvaluation | Measured],
    *,
    baseline: str = "shortest",
    random: str = "random",
) -> list[tuple[str, str]]:
    """``(policy, reference)`` for each policy of ``evaluations`` that does worse than
    ``baseline`` or ``random`` (those present): fewer packages delivered one-shot, a lower
    throughput lifelong."""
    return [
        (name, reference)
        for name, evaluation in evaluations.items()
        for reference in (baseline, random)
        if name != reference
        and reference in evaluations
        and _score(evaluation) < _score(evaluations[reference])
    ]


def compare_policies(
    evaluations: dict[str, FleetEvaluation | ThroughputEvaluation | Measured],
    *,
    baseline: str = "shortest",
    random: str = "random",
) -> str:
    """A side-by-side table of ``evaluations`` (by policy name), then one line for each
    policy that does worse than ``baseline`` or ``random`` (when those are present):
    fewer packages delivered one-shot, a lower throughput lifelong. The evaluations
    are all one-shot or all lifelong."""
    if not evaluations:
        return ""
    width = max(len(name) for name in evaluations)
    lines = [f"{name:<{width}}  {ev.summary()}" for name, ev in evaluations.items()]
    for name, reference in worse_policies(evaluations, baseline=baseline, random=random):
        ev, ref = evaluations[name], evaluations[reference]
        if isinstance(ev, FleetEvaluation) and isinstance(ref, FleetEvaluation):
            what = f"fewer packages ({ev.delivered} < {ref.delivered})"
        else:
            rates = f"{ev.throughput:.2f} < {ref.throughput:.2f}"
            what = f"a lower throughput ({rates} deliveries/step)"
        lines.append(f"WORSE: {name} delivers {what} than {reference}")
    return "\n".join(lines)
