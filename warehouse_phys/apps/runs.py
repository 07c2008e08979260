"""One training run, from its configuration to a complete run folder.

What ``python -m warehouse_phys.train`` and ``python -m warehouse_phys.sweep``
share: the floor to train on (:class:`Floor`), the files a run writes and
:func:`train_run`, which trains, evaluates and writes them into a
:class:`~warehouse_phys.files.runfolder.RunFolder`.

One training run, single or fleet, from floor to folder: its length is the run folder's
files (summary, table, figures, GIF), which train and sweep share.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import partial
from typing import Any

import gymnasium as gym
import numpy as np

import warehouse_phys
from warehouse_phys.drawing.animation import Animation
from warehouse_phys.drawing.render import DEFAULT_CELL_PX, MIN_CELL_PX
from warehouse_phys.envs.fleet import WarehouseFleetEnv, parallel_env
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.files.runfolder import RunFolder
from warehouse_phys.rl.fleet_learning import (
    FLEET_EVAL_EPSILON,
    FLEET_PATIENCE,
    FleetEvaluation,
    evaluate_fleet,
    fleet_table_metadata,
    greedy_fleet_policy,
    random_fleet_policy,
    shortest_path_policy,
    train_fleet,
    training_steps,
)
from warehouse_phys.rl.greedy_policy import Evaluation, evaluate, greedy_action
from warehouse_phys.rl.qlearning import (
    QLearningConfig,
    TrainingResult,
    save_q_table,
    table_metadata,
    train,
)
from warehouse_phys.viz.recording import EpisodeRecording, record_episode, record_fleet_episode
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import PRESETS, preset_ids, resolve_layout, suggested_time_limit

#: The environment kinds and the ids they stand for.
ENVIRONMENTS = {"phys": warehouse_phys.PHYSICS_ENV_ID, "grid": warehouse_phys.GRID_ENV_ID}

TABLE_FILE, CURVE_FILE, SUMMARY_FILE = "qtable.npz", "learning_curve.png", "summary.json"
GIF_FILE = "episode.gif"
#: Every file a run may write into its folder.
RUN_FILES = (TABLE_FILE, CURVE_FILE, GIF_FILE, SUMMARY_FILE)
#: The greedy episode in the GIF stops after this many steps, should the policy wander [steps].
GIF_MAX_STEPS = 60
#: Longest side of the floor in a training GIF's frame [px] (the status line is below it):
#: a large floor is drawn with smaller cells, down to the renderer's least (a 90 x 90 floor
#: at 64 px a cell made 100 MB frames, and its GIF took 17 GB).
GIF_FRAME_PX = 1024
#: Most memory the GIF's frames may take [bytes]: a large floor's GIF has fewer steps.
GIF_FRAME_BYTES = 128 * 2**20
#: The learning curve in ``summary.json``: at most this many points [1].
CURVE_POINTS = 200
#: The seeds a fleet's policies are evaluated with, the same for every run.
EVALUATION_SEEDS = range(20)


@dataclass(frozen=True)
class Floor:
    """The floor to use: the empty one, a preset, or a layout's rows; and its time limit."""

    rows: int | None = None
    cols: int | None = None
    preset: str | None = None
    layout: tuple[str, ...] | None = None
    #: A short name for run folders: the preset's name or the layout file's stem.
    label: str | None = None
    #: The episodes' time limit; ``None`` for the floor's suggested one.
    max_steps: int | None = None

    def grid(self) -> WarehouseGrid:
        """The world model of this floor."""
        if self.preset is not None:
            return resolve_layout(self.preset)
        if self.layout is not None:
            return WarehouseGrid.from_layout(self.layout)
        return WarehouseGrid(self.rows or 4, self.cols or 5)

    def time_limit(self) -> int:
        """``max_steps``, or the preset's registered limit, or
        :func:`~warehouse_phys.world.layouts.suggested_time_limit` of the floor."""
        if self.max_steps is not None:
            return self.max_steps
        if self.preset is not None:
            return PRESETS[self.preset].max_episode_steps
        return suggested_time_limit(self.grid())

    def env_id(self, kind: str) -> str:
        """The id of the ``kind`` ("grid" or "phys") environment on this floor."""
        if self.preset is not None:
            grid_id, physics_id = preset_ids(self.preset)
            return physics_id if kind == "phys" else grid_id
        return ENVIRONMENTS[kind]

    def make(self, kind: str, render_mode: str | None = None, **drawing: int) -> gym.Env:
        """The ``kind`` ("grid" or "phys") environment on this floor, through ``gym.make``
        (``drawing``: ``cell_px``, the size of a drawn cell).

        Ids are given in ``warehouse_phys:`` form, which imports the package in
        any process (a Ray worker, a spawned subprocess) before looking them up.
        """
        limit = self.time_limit()
        env_id = f"warehouse_phys:{self.env_id(kind)}"
        if self.preset is not None:
            return gym.make(env_id, render_mode=render_mode, max_episode_steps=limit, **drawing)
        if self.layout is not None:
            return gym.make(
                env_id,
                layout=list(self.layout),
                render_mode=render_mode,
                max_episode_steps=limit,
                **drawing,
            )
        return gym.make(
            env_id,
            grid_rows=self.rows or 4,
            grid_cols=self.cols or 5,
            render_mode=render_mode,
            max_episode_steps=limit,
            **drawing,
        )

    def make_fleet(
        self, kind: str, robots: int, render_mode: str | None = None, observation: str = "local"
    ) -> WarehouseFleetEnv:
        """A fleet of ``robots`` on this floor, in the ``kind`` world, with its time limit."""
        floor: dict[str, Any] = {"grid_rows": self.rows or 4, "grid_cols": self.cols or 5}
        if self.preset is not None:
            floor = {"layout": self.preset}
        elif self.layout is not None:
            floor = {"layout": list(self.layout)}
        return parallel_env(
            num_robots=robots,
            physics=kind == "phys",
            max_cycles=self.time_limit(),
            render_mode=render_mode,
            observation=observation,
            **floor,
        )


@dataclass(frozen=True)
class RunOutcome:
    """What a run did: the table and records, the evaluation and the summary it wrote."""

    env_id: str
    max_episode_steps: int
    result: TrainingResult
    evaluation: Evaluation
    seconds: float
    summary: dict[str, Any]
    gif_written: bool


def train_run(
    folder: RunFolder,
    floor: Floor,
    kind: str,
    config: QLearningConfig,
    *,
    gif: bool = True,
    on_episode: Callable[[int], None] | None = None,
) -> RunOutcome:
    """Train on ``floor`` in the ``kind`` environment, evaluate, and write the run into
    ``folder`` (opened by the caller): table, learning curve, the greedy episode's
    GIF (unless ``gif`` is false) and ``summary.json``, each atomically.

    Raises:
        warehouse_phys.files.runfolder.RunWriteError: naming the file that could not be written.
    """
    started = time.localtime()
    env = floor.make(kind)
    start = time.perf_counter()
    result = train(env, config, on_episode=on_episode)
    seconds = time.perf_counter() - start
    evaluation = evaluate(env, result.q)
    env.close()
    episode = greedy_episode(floor, kind, result.q, seed=config.seed) if gif else None
    metadata = table_metadata(env, config)
    last = _last_100(result)
    summary = _write_run(
        folder,
        result,
        metadata,
        title=f"{metadata['env_id']} {metadata['grid_rows']}x{metadata['grid_cols']}, "
        f"seed {config.seed}",
        head={
            "env_id": metadata["env_id"],
            **_floor_summary(metadata),
            "max_episode_steps": env.spec.max_episode_steps,
        },
        started=started,
        seconds=seconds,
        training={
            "episodes": len(result.steps),
            "reached_target": int(result.reached_target.sum()),
            "truncated": int(result.truncated.sum()),
            "total_steps": int(result.steps.sum()),
            "mean_steps_last_100": float(result.steps[last].mean()),
            "success_rate_last_100": float(result.reached_target[last].mean()),
        },
        evaluation=evaluation.to_json(),
        gif=None if episode is None else partial(_single_gif, episode, config.seed),
    )
    return RunOutcome(
        env.spec.id, env.spec.max_episode_steps, result, evaluation, seconds, summary,
        episode is not None,
    )  # fmt: skip


@dataclass(frozen=True)
class FleetRunOutcome:
    """What a fleet's run did: the shared table and records, the evaluations of the
    learned policy and of the shortest-path baseline, and the summary it wrote."""

    env_id: str
    robots: int
    max_cycles: int
    result: TrainingResult
    evaluation: FleetEvaluation
    baseline: FleetEvaluation
    #: Every policy evaluated on the same seeds, by name: learned, shortest, random, pibt.
    comparison: dict[str, FleetEvaluation]
    seconds: float
    summary: dict[str, Any]
    gif_written: bool


def train_fleet_run(
    folder: RunFolder,
    floor: Floor,
    kind: str,
    robots: int,
    config: QLearningConfig,
    *,
    gif: bool = True,
    on_episode: Callable[[int], None] | None = None,
    observation: str = "local",
) -> FleetRunOutcome:
    """Train a fleet of ``robots`` sharing one table on ``floor`` in the ``kind`` world,
    evaluate it beside the shortest-path policy, the random one and the PIBT planner
    over fixed seeds (:func:`fleet_comparison`), and write the run
    into ``folder``: the table, the learning curve, a GIF of the fleet's greedy
    episode (unless ``gif`` is false) and ``summary.json``, each atomically.

    Raises:
        warehouse_phys.files.runfolder.RunWriteError: naming the file that could not be written.
        ValueError: if the floor cannot hold the fleet (too few start or package cells).
    """
    started = time.localtime()
    env = floor.make_fleet(kind, robots, observation=observation)
    start = time.perf_counter()
    result = train_fleet(env, config, on_episode=on_episode)
    seconds = time.perf_counter() - start
    comparison = fleet_comparison(env, result.q)
    evaluation, baseline = comparison["learned"], comparison["shortest"]
    env_id = floor.env_id(kind)
    metadata = fleet_table_metadata(env, config, env_id)
    env.close()

    def record_gif() -> tuple[Animation, dict[str, Any]]:
        shown = floor.make_fleet(kind, robots, render_mode="rgb_array", observation=observation)
        try:
            animation, delivered = record_fleet_episode(
                shown, greedy_fleet_policy(result.q), seed=config.seed, max_steps=GIF_MAX_STEPS
            )
        finally:
            shown.close()
        return animation, {"seed": config.seed, "delivered": delivered}

    summary = _write_run(
        folder,
        result,
        metadata,
        title=f"{robots} robots, {env_id} {env.grid.rows}x{env.grid.cols}, seed {config.seed}",
        head={
            "env_id": env_id,
            "robots": robots,
            **_floor_summary(metadata),
            "max_cycles": env.max_cycles,
        },
        started=started,
        seconds=seconds,
        training={
            "episodes": len(result.steps),
            "max_steps": min(env.max_cycles, training_steps(env.grid.rows, env.grid.cols)),
            "all_delivered": int(result.reached_target.sum()),
            "truncated": int(result.truncated.sum()),
            "mean_steps_last_100": float(result.steps[_last_100(result)].mean()),
        },
        evaluation={
            "seeds": [EVALUATION_SEEDS.start, EVALUATION_SEEDS.stop],
            "learned": evaluation.to_json(),
            "learned_epsilon": FLEET_EVAL_EPSILON,
            "learned_patience": FLEET_PATIENCE,
            "shortest_path": baseline.to_json(),
            "random": comparison["random"].to_json(),
            "pibt": comparison["pibt"].to_json(),
        },
        gif=record_gif if gif else None,
    )
    return FleetRunOutcome(
        env_id, robots, env.max_cycles, result, evaluation, baseline, comparison, seconds,
        summary, gif,
    )  # fmt: skip


def fleet_comparison(env: WarehouseFleetEnv, q: Any) -> dict[str, FleetEvaluation]:
    """The learned table's policy (:func:`greedy_fleet_policy`), the shortest-path
    baseline, the random policy and the PIBT planner on ``env``, over
    :data:`EVALUATION_SEEDS`, by name."""
    from warehouse_phys.rl.fleet_planners import pibt_policy

    policies = {
        "learned": greedy_fleet_policy(q),
        "shortest": shortest_path_policy,
        "random": random_fleet_policy(0),
        "pibt": pibt_policy(0),
    }
    return {name: evaluate_fleet(env, policy, seeds=EVALUATION_SEEDS)
            for name, policy in policies.items()}  # fmt: skip


def greedy_episode(floor: Floor, kind: str, q: Any, *, seed: int) -> EpisodeRecording:
    """The greedy policy's episode with ``seed``, recorded for the GIF: smooth motion
    in the physics-backed environment, one jump per step in the grid twin."""
    grid = floor.grid()
    cell_px = min(DEFAULT_CELL_PX, max(MIN_CELL_PX, GIF_FRAME_PX // max(grid.rows, grid.cols)))
    frame_bytes = 3 * cell_px**2 * (grid.rows + 1) * grid.cols  # a row more: the status line
    steps = max(1, min(GIF_MAX_STEPS, GIF_FRAME_BYTES // frame_bytes - 1))
    env = floor.make(kind, render_mode="rgb_array", cell_px=cell_px)
    try:
        return record_episode(env, partial(greedy_action, q), seed=seed, max_steps=steps)
    finally:
        env.close()


def learning_curve_points(steps: np.ndarray, window: int = 100) -> dict[str, list[float]]:
    """The rolling mean of steps per episode over ``window`` episodes (fewer in a short
    run: a twentieth of it), at most :data:`CURVE_POINTS` points:
    ``{"episodes": [...], "mean_steps": [...], "window": w}``."""
    steps = np.asarray(steps, dtype=np.float64)
    window = max(1, min(window, len(steps) // 20))
    sums = np.cumsum(np.concatenate([[0.0], steps]))
    ends = np.arange(window, len(steps) + 1)
    means = (sums[ends] - sums[ends - window]) / window
    picked = np.unique(np.linspace(0, len(means) - 1, min(CURVE_POINTS, len(means))).astype(int))
    return {
        "episodes": [int(ends[i]) for i in picked],
        "mean_steps": [round(float(means[i]), 4) for i in picked],
        "window": window,
    }


def _write_run(
    folder: RunFolder,
    result: TrainingResult,
    metadata: dict[str, Any],
    *,
    title: str,
    head: dict[str, Any],
    started: time.struct_time,
    seconds: float,
    training: dict[str, Any],
    evaluation: dict[str, Any],
    gif: Callable[[], tuple[Animation, dict[str, Any]]] | None,
) -> dict[str, Any]:
    """Write a run's files into ``folder``, each atomically, in this order: the table with
    its ``metadata``, the learning curve titled ``title``, the GIF of the episode that
    ``gif()`` records (with what the summary says of it; none if ``gif`` is ``None``),
    and ``summary.json``. The summary is ``head`` (what ran, on which floor), then the
    configuration, the version, the start and the training time, ``training`` (the
    records in numbers), the learning curve, ``evaluation`` and the files; returns it."""
    from warehouse_phys.viz.figures import save_figure
    from warehouse_phys.viz.plots import learning_curve_figure

    folder.write(TABLE_FILE, lambda path: save_q_table(path, result.q, metadata))
    figure = learning_curve_figure(result, title)
    folder.write(CURVE_FILE, lambda path: save_figure(figure, path))
    summary: dict[str, Any] = {
        **head,
        "config": asdict(result.config),
        "package_version": warehouse_phys.__version__,
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", started),
        "training_seconds": round(seconds, 4),
        "training": training,
        "learning_curve": learning_curve_points(result.steps),
        "evaluation": evaluation,
        "files": {"table": TABLE_FILE, "learning_curve": CURVE_FILE},
    }
    if gif is not None:
        animation, episode = gif()
        folder.write(GIF_FILE, animation.save)
        summary["files"]["episode_gif"] = GIF_FILE
        summary["gif_episode"] = episode
    text = json.dumps(summary, indent=2) + "\n"
    folder.write(SUMMARY_FILE, lambda path: atomic_write_text(path, text))
    return summary


def _floor_summary(metadata: dict[str, Any]) -> dict[str, Any]:
    """The floor of a table's ``metadata``, as a run's summary gives it."""
    return {
        "grid": [metadata["grid_rows"], metadata["grid_cols"]],
        "layout": metadata["layout"],
        "layout_name": metadata["layout_name"],
    }


def _last_100(result: TrainingResult) -> slice:
    """The last 100 episodes of ``result`` (all of a shorter run)."""
    return slice(-min(100, len(result.steps)), None)


def _single_gif(episode: EpisodeRecording, seed: int) -> tuple[Animation, dict[str, Any]]:
    """The GIF of a single robot's recorded greedy ``episode`` and what the summary says
    of it."""
    return episode.animation(), {
        "seed": seed,
        "target": list(episode.target),
        "steps": episode.steps,
        "reached_target": episode.terminated,
    }
