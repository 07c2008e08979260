"""What a run of ``simulate`` measured and the run folder it writes: what both modes share.

The command line (:mod:`warehouse_phys.apps.simulate`) runs one of two modes, the
lock-step run (:mod:`warehouse_phys.apps.simulate.lockstep`) and the run on ticks and
delays (:mod:`warehouse_phys.apps.simulate.on_ticks`); both stand on this module:

- :class:`Simulation`, a run's record: its measures in one line, its ``summary.json``,
  the CPU time of its reset, steps and frames; a run on ticks' record is a subclass;
- :data:`DEFAULT_STEPS` and :data:`INSTANCE_STEPS`, a run's length by default;
- :func:`make_policy`, the fleet policies by name (``--policy``);
- :func:`write_run_files`, the run folder's ``summary.json`` (with the comparison against
  the baselines), ``throughput.png``, ``congestion.png`` and ``fleet.gif``, and
  :func:`write_lorr_output`, an instance's ``lorr-output.json``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.lorr.instances import PUBLISHED_FIGURES
from warehouse_phys.lorr.output import RunRecord, write_output
from warehouse_phys.rl.fleet_evaluation import (
    FleetPolicy,
    random_fleet_policy,
    shortest_path_policy,
    worse_policies,
)
from warehouse_phys.rl.fleet_planners import PLANNERS, TURNING_ONLY, planner_policy

#: The baselines by name: shortest moves (waiting when blocked), and random moves.
BASELINE_POLICIES = ("shortest", "random")
#: Every policy ``--policy`` takes by name: each planner of
#: :data:`~warehouse_phys.rl.fleet_planners.PLANNERS` (their one list), then the baselines.
POLICIES = (*PLANNERS, *BASELINE_POLICIES)
RUN_FILES = ("summary.json", "throughput.png", "congestion.png", "fleet.gif", "lorr-output.json")
#: Steps of a run by default, and of an instance's (the competition's count).
DEFAULT_STEPS, INSTANCE_STEPS = 256, 5000


@dataclass(frozen=True)
class Simulation:
    """What a fleet did in one run of
    :func:`~warehouse_phys.apps.simulate.lockstep.simulate`."""

    layout: str
    robots: int
    policy: str
    seed: int
    on_delivery: str
    physics: bool
    #: Deliveries at each joint step.
    deliveries: np.ndarray
    #: Waits counted on each cell, ``(rows, cols)``: a robot that had not delivered and
    #: stayed on its cell for a step (asked to WAIT, refused or bumping).
    waits: np.ndarray
    #: Moves that traffic turned into waits.
    refused: int
    #: Seconds of CPU time the steps took, the environment and the policy together
    #: (frames apart; the reset is ``reset_seconds``).
    cpu_seconds: float
    #: One-shot runs only (``on_delivery`` ``"park"`` or ``"leave"``): the step at which
    #: each robot delivered, 0 for a robot that did not, ``(robots,)``.
    delivered_at: np.ndarray | None = None
    #: One-shot runs only: each robot's shortest path to its package from its start.
    shortest: np.ndarray | None = None
    #: One-shot runs only: undelivered packages that parked robots wall off at the end.
    walled_off: int = 0
    #: CPU seconds of the reset, and of each step (policy and environment, no frames).
    reset_seconds: float = 0.0
    step_seconds: np.ndarray | None = None
    #: CPU seconds of drawing each frame.
    frame_seconds: np.ndarray | None = None
    #: ``"grid"`` or ``"rotate"``.
    moves: str = "grid"
    #: An instance run: the instance's name and the tasks finished at each step.
    instance: str | None = None
    #: What of the instance this run does not model, in words (a lock-step run of a 2026
    #: instance: its ticks and delays; a run on ticks: turning robots, square robots).
    not_simulated: tuple[str, ...] = ()
    tasks: np.ndarray | None = None
    #: A 2024 or later instance's scheduler, by its name (None for the others).
    scheduler: str | None = None
    #: Physics runs: the bodies' measured safety
    #: (:meth:`~warehouse_phys.physics.safety.SafetyRecord.summary`: closest approach,
    #: contacts deeper than the collision slop, ...), top-level fields of ``summary.json``.
    safety: dict[str, Any] | None = None
    #: A guided planner's fields set on the command line (``--guidance``; None: its
    #: defaults), recorded in ``summary.json``.
    guidance: dict[str, Any] | None = None

    @property
    def steps(self) -> int:
        return len(self.deliveries)

    @property
    def one_shot(self) -> bool:
        return self.delivered_at is not None

    @property
    def delivered(self) -> int:
        """Robots that delivered their package (one-shot), or deliveries (lifelong)."""
        if self.delivered_at is None:
            return int(self.deliveries.sum())
        return int(np.count_nonzero(self.delivered_at))

    @property
    def makespan(self) -> int:
        """One-shot: the step of the last delivery, or the run's length when a robot did
        not deliver."""
        if self.delivered_at is None or not self.delivered_at.all():
            return self.steps
        return int(self.delivered_at.max()) if len(self.delivered_at) else 0

    @property
    def sum_of_costs(self) -> int:
        """One-shot: each robot's steps until it delivered, an undelivered robot counted at
        the run's length, summed."""
        if self.delivered_at is None:
            return 0
        return int(np.where(self.delivered_at > 0, self.delivered_at, self.steps).sum())

    @property
    def throughput(self) -> float:
        """Deliveries per step."""
        return float(self.deliveries.mean()) if self.steps else 0.0

    def measures(self) -> str:
        """The measures in one line: throughput, deliveries, waits and refused moves; and
        one-shot, the makespan and the sum of costs against the shortest paths'; an
        instance run counts errands and tasks, beside the published figure."""
        if self.tasks is not None:
            return self._instance_measures()
        line = (
            f"throughput {self.throughput:.2f} deliveries/step, "
            f"{int(self.deliveries.sum()):,} deliveries, {int(self.waits.sum()):,} waits, "
            f"{self.refused:,} refused moves"
        )
        if self.delivered_at is not None and self.shortest is not None:
            walled = f" ({self.walled_off:,} walled off)" if self.walled_off else ""
            line += (
                f"; {self.delivered:,}/{self.robots:,} delivered{walled}, makespan "
                f"{self.makespan}, sum of costs {self.sum_of_costs:,} against "
                f"{int(self.shortest.sum()):,} on shortest paths"
            )
        return line

    def _instance_measures(self) -> str:
        steps = max(self.steps, 1)
        errands, tasks = int(self.deliveries.sum()), int(self.tasks.sum())
        line = (
            f"{errands / steps:.2f} errands/step, {tasks / steps:.2f} tasks/step ({errands:,} "
            f"errands, {tasks:,} tasks), {int(self.waits.sum()):,} waits, "
            f"{self.refused:,} refused moves"
        )
        published = PUBLISHED_FIGURES.get(self.instance or "")
        if published is not None:
            line += f"; published on {self.instance}: {published.describe()}"
        return line

    def lorr_output_options(self) -> dict[str, Any]:
        """Keywords of :func:`~warehouse_phys.lorr.output.write_output` beyond the
        record: none in lock step (a run on ticks adds its ticks and delays)."""
        return {}

    def figure_options(self) -> dict[str, Any]:
        """Keywords of :func:`~warehouse_phys.viz.plots.throughput_figure`: none in lock
        step (a run on ticks counts ticks)."""
        return {}

    def summary(self) -> str:
        what = "" if self.tasks is None else f", {self.moves} moves"
        return (
            f"{self.policy}, {self.robots:,} robots on {self.layout}, {self.steps} steps "
            f"({self.on_delivery}{what}): {self.measures()}"
        )

    def timing(self) -> dict[str, float]:
        """CPU seconds: the reset, the first step, the median and the slowest of the others
        (no step counts a frame); the frames' drawing, all together and the median one."""
        times = np.zeros(0) if self.step_seconds is None else self.step_seconds
        frames = np.zeros(0) if self.frame_seconds is None else self.frame_seconds
        later = times[1:] if len(times) > 1 else times
        return {
            "reset": self.reset_seconds,
            "first_step": float(times[0]) if len(times) else 0.0,
            "median_step": float(np.median(later)) if len(later) else 0.0,
            "max_step": float(later.max()) if len(later) else 0.0,
            "frames": float(frames.sum()),
            "median_frame": float(np.median(frames)) if len(frames) else 0.0,
        }

    def to_json(self) -> dict[str, Any]:
        return {
            "layout": self.layout,
            "robots": self.robots,
            "policy": self.policy,
            "seed": self.seed,
            "on_delivery": self.on_delivery,
            "physics": self.physics,
            "steps": self.steps,
            "throughput": self.throughput,
            "deliveries": int(self.deliveries.sum()),
            "waits": int(self.waits.sum()),
            "refused": self.refused,
            "cpu_seconds": self.cpu_seconds,
            "cpu_seconds_of": self.timing(),
            "moves": self.moves,
            **({"guidance": self.guidance} if self.guidance else {}),
            **self._one_shot_json(),
            **self._instance_json(),
            **(self.safety or {}),
            "deliveries_per_step": self.deliveries.tolist(),
        }

    def safety_measures(self) -> str | None:
        """A physics run's measured safety in one line (``None`` for other runs)."""
        if not self.safety:
            return None
        closest, bound = self.safety["closest_approach"], self.safety["closest_approach_bound"]
        near = "no two within a cell" if closest is None else f"{closest:.3f} cells"
        return (
            f"bodies: closest approach {near} (the twin's bound: {bound:.3f}); contacts "
            f"deeper than the collision slop: {self.safety['body_contacts']:,} body-body, "
            f"{self.safety['wall_contacts']:,} body-wall"
        )

    def _instance_json(self) -> dict[str, Any]:
        if self.tasks is None:
            return {}
        steps = max(self.steps, 1)
        published = PUBLISHED_FIGURES.get(self.instance or "")
        return {
            "instance": self.instance,
            "errands": int(self.deliveries.sum()),
            "errands_per_step": int(self.deliveries.sum()) / steps,
            "tasks": int(self.tasks.sum()),
            "tasks_per_step": int(self.tasks.sum()) / steps,
            "published": None if published is None else published.to_json(),
            "not_simulated": list(self.not_simulated),
            "scheduler": self.scheduler,
            "tasks_per_step_series": self.tasks.tolist(),
        }

    def _one_shot_json(self) -> dict[str, Any]:
        if self.delivered_at is None or self.shortest is None:
            return {}
        return {
            "delivered": self.delivered,
            "undelivered": self.robots - self.delivered,
            "walled_off": self.walled_off,
            "makespan": self.makespan,
            "sum_of_costs": self.sum_of_costs,
            "shortest_paths": int(self.shortest.sum()),
        }


def make_policy(
    name: str, env: WarehouseFleetEnv, *, seed: int, guidance: Mapping[str, Any] | None = None
) -> FleetPolicy:
    """The fleet policy called ``name``: one of :data:`POLICIES` or a fleet table's path;
    ``guidance`` sets a guided planner's fields
    (:func:`~warehouse_phys.rl.fleet_planners.planner_policy`).

    Raises:
        ValueError: for an unknown name, a planner of turning robots for robots that do
            not turn, or a table that does not fit ``env``'s floor.
    """
    if name in TURNING_ONLY and getattr(env, "moves", "grid") != "rotate":
        raise ValueError(f"policy {name!r} plans turning robots only: give --moves rotate")
    if name in PLANNERS:
        return planner_policy(name, seed=seed, **(guidance or {}))
    if name == "shortest":
        return shortest_path_policy
    if name == "random":
        return random_fleet_policy(seed)
    if name.endswith(".npz"):
        from warehouse_phys.rl.fleet_learning import greedy_fleet_policy
        from warehouse_phys.rl.qlearning import QTableError, load_q_table

        try:
            q, _ = load_q_table(name, rows=env.grid.rows, cols=env.grid.cols)
        except QTableError as error:
            raise ValueError(str(error)) from None
        expected = [*env.observation_space(env.possible_agents[0]).nvec.tolist(), 5]
        if list(q.shape) != expected:
            raise ValueError(
                f"{name}: a table of shape {q.shape} does not fit this fleet's observations "
                f"(expected {tuple(expected)})"
            )
        return greedy_fleet_policy(q)
    raise ValueError(f"unknown policy {name!r}: choose {', '.join(POLICIES)} or a table (.npz)")


def write_lorr_output(folder: Any, env: Any, result: Simulation, record: RunRecord) -> None:
    """Write ``lorr-output.json`` into ``folder`` (a run folder): the competition's output
    file of ``env``'s instance run, from ``record`` and the run's own options
    (:meth:`Simulation.lorr_output_options`)."""
    instance, errands = env.instance, env.errands
    options = result.lorr_output_options()
    folder.write(
        "lorr-output.json",
        lambda path: write_output(path, instance, record, errands, **options),
    )


def write_run_files(
    folder: Any,
    env: Any,
    result: Simulation,
    frames: list,
    runs: dict[str, Simulation],
) -> None:
    """Write ``result``'s files into ``folder`` (a run folder): ``summary.json`` (with
    the measures of ``runs``, the baselines', and the policies that did worse, when there
    are several), ``throughput.png``, ``congestion.png`` (the waits on ``env``'s floor)
    and, given ``frames``, ``fleet.gif``."""
    from warehouse_phys.drawing.animation import Animation
    from warehouse_phys.files.atomic import atomic_write_text
    from warehouse_phys.viz.figures import save_figure
    from warehouse_phys.viz.throughput_figures import congestion_figure, throughput_figure

    summary = result.to_json()
    if len(runs) > 1:
        keys = ("throughput", "deliveries", "waits", "refused")
        summary["comparison"] = {
            name: {key: run.to_json()[key] for key in keys} for name, run in runs.items()
        }
        worse = worse_policies(runs)
        summary["worse_than"] = [{"policy": name, "reference": ref} for name, ref in worse]
    text = json.dumps(summary, indent=2) + "\n"
    folder.write("summary.json", lambda path: atomic_write_text(path, text))
    folder.write(
        "throughput.png",
        lambda path: save_figure(
            throughput_figure(result.deliveries, result.summary(), **result.figure_options()), path
        ),
    )
    folder.write(
        "congestion.png", lambda path: save_figure(congestion_figure(env.grid, result.waits), path)
    )
    if frames:
        folder.write("fleet.gif", lambda path: Animation(frames, fps=8).save(path))
