"""A sweep's trials and its results table.

The command line's floors, hyper-parameters and seeds become :data:`Setting` s (each
checked once, the grid's size refused above :data:`MAX_TRIALS` before a trial is
built), then :class:`Trial` s, each with its run folder under the sweep folder and the
plain values a worker needs (:meth:`Trial.to_job`). A trial's row of the results table
holds its settings, its status and the measures of its run's summary (:data:`COLUMNS`);
:func:`write_results` writes ``results.csv``, ``results.json`` and ``summary.png``.
"""

from __future__ import annotations

import argparse
import csv
import io
import itertools
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from warehouse_phys.apps.cli import UsageError, floor_from_layout
from warehouse_phys.apps.runs import SUMMARY_FILE, Floor
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.rl.qlearning import QLearningConfig, check_training_memory
from warehouse_phys.world.layouts import PRESETS

#: The floor named ``default`` in ``--layout``: the plain floor of ``--rows`` x ``--cols``.
DEFAULT_FLOOR = "default"
#: The sweep's tables and figure, in the sweep folder.
RESULTS_CSV, RESULTS_JSON, SUMMARY_PNG = "results.csv", "results.json", "summary.png"
#: The driver's lock file in the sweep folder: its pid and its run's token. Each trial's
#: job names it (:meth:`Trial.to_job`); :mod:`~warehouse_phys.apps.sweep.resume` takes it.
LOCK_FILE = "sweep.lock"
#: Most seeds in one ``--seeds``: each is a trial (times the other settings) and a folder.
MAX_SEEDS = 10_000
#: Most trials in one sweep [trials]: each is a Tune trial, a run folder and a row.
MAX_TRIALS = 10_000
#: The columns of ``results.csv``, in order.
COLUMNS = (
    "trial",
    "env",
    "floor",
    "alpha",
    "gamma",
    "episodes",
    "seed",
    "status",
    "fraction_optimal",
    "targets",
    "reached",
    "optimal",
    "mean_steps_to_target",
    "training_episodes",
    "training_seconds",
    "folder",
    "error",
)


@dataclass(frozen=True)
class Trial:
    """One training run of the sweep: what to train, and the folder it writes."""

    env: str
    floor_name: str
    floor: Floor
    alpha: float
    gamma: float
    episodes: int
    seed: int
    #: The run folder, relative to the sweep folder.
    folder: str

    @property
    def name(self) -> str:
        return Path(self.folder).name

    @property
    def configuration(self) -> str:
        """The trial's settings but its seed: the group it belongs to in ``summary.png``."""
        return (
            f"{self.env} {self.floor_name} alpha={self.alpha:g} gamma={self.gamma:g} "
            f"{self.episodes} episodes"
        )

    def to_job(self, sweep_dir: Path, gif: bool, run: str | None = None) -> dict[str, Any]:
        """What a worker needs, as plain values (sent to Ray workers); with ``run``, the
        token of the sweep's run (see :func:`~warehouse_phys.apps.sweep.resume.take_sweep_lock`),
        which the worker checks."""
        return {
            "env": self.env,
            "floor": asdict(self.floor),
            "config": {
                "episodes": self.episodes,
                "alpha": self.alpha,
                "gamma": self.gamma,
                "seed": self.seed,
            },
            "folder": str((sweep_dir / self.folder).resolve()),
            "gif": gif,
            "name": self.name,
            "lock": str((sweep_dir / LOCK_FILE).resolve()),
            "run": run,
        }


#: One configuration of the grid but its seeds: environment, floor's name, floor,
#: learning rate, discount and the episode counts to train for.
Setting = tuple[str, str, Floor, float, float, list[int]]


def settings_from_args(args: argparse.Namespace) -> list[Setting]:
    """Every combination the arguments ask for but the seeds, each checked once: what a
    sweep is, before its trials are built.

    Raises:
        UsageError: for a bad floor, hyper-parameter, a floor too big to train on, or
            a grid of more than :data:`MAX_TRIALS` trials (before any trial is built).
    """
    floors: dict[str, Floor] = {}
    for name in dict.fromkeys(args.layout):  # in order, without repeats
        if name == DEFAULT_FLOOR:
            floors[name] = Floor(rows=args.rows, cols=args.cols, label=DEFAULT_FLOOR)
        else:
            floor = floor_from_layout(name)
            floors[floor.label or name] = floor
    settings: list[Setting] = []
    for env, (floor_name, floor), alpha, gamma in itertools.product(
        dict.fromkeys(args.env), floors.items(), dict.fromkeys(args.alpha),
        dict.fromkeys(args.gamma),
    ):  # fmt: skip
        episode_counts = list(dict.fromkeys(args.episodes or [
            PRESETS[floor.preset].training_episodes if floor.preset else 1000
        ]))  # fmt: skip
        grid = floor.grid()
        for episodes in episode_counts:  # the seeds, checked by --seeds, change nothing here
            try:
                QLearningConfig(episodes=episodes, alpha=alpha, gamma=gamma, seed=args.seeds[0])
                check_training_memory(grid.rows, grid.cols, episodes)
            except ValueError as error:
                raise UsageError(str(error)) from None
        settings.append((env, floor_name, floor, alpha, gamma, episode_counts))
    count = sum(len(setting[-1]) for setting in settings) * len(args.seeds)
    if count > MAX_TRIALS:
        raise UsageError(
            f"--env, --layout, --alpha, --gamma, --episodes and --seeds ask for {count:,} "
            f"trials, more than the {MAX_TRIALS:,} a sweep may run; split it into smaller sweeps"
        )
    return settings


def expand_trials(settings: Sequence[Setting], seeds: Sequence[int]) -> list[Trial]:
    """The trials of ``settings`` (from :func:`settings_from_args`) times ``seeds``, in
    order, each with its folder name."""
    trials = []
    for (env, floor_name, floor, alpha, gamma, episode_counts), seed in itertools.product(
        settings, seeds
    ):
        for episodes in episode_counts:
            name = f"{env}-{floor_name}-a{alpha:g}-g{gamma:g}-e{episodes}-seed{seed}"
            trials.append(
                Trial(env, floor_name, floor, alpha, gamma, episodes, seed, f"runs/{name}")
            )
    return trials


def trials_from_args(args: argparse.Namespace) -> list[Trial]:
    """Every trial the arguments ask for, each with its folder name.

    Raises:
        UsageError: as :func:`settings_from_args`.
    """
    return expand_trials(settings_from_args(args), args.seeds)


def _measures(summary: dict[str, Any]) -> dict[str, Any]:
    """The figures of a run's summary that the results table holds."""
    evaluation = summary["evaluation"]
    steps = [r["steps"] for r in evaluation["results"] if r["steps"] is not None]
    return {
        "fraction_optimal": evaluation["optimal"] / evaluation["targets"],
        "targets": evaluation["targets"],
        "reached": evaluation["reached"],
        "optimal": evaluation["optimal"],
        "mean_steps_to_target": sum(steps) / len(steps) if steps else None,
        "training_episodes": summary["training"]["episodes"],
        "training_seconds": summary["training_seconds"],
    }


def _row(trial: Trial, status: str, measures: dict[str, Any], error: str = "") -> dict[str, Any]:
    row = dict.fromkeys(COLUMNS, None)
    row.update(
        trial=trial.name, env=trial.env, floor=trial.floor_name, alpha=trial.alpha,
        gamma=trial.gamma, episodes=trial.episodes, seed=trial.seed, status=status,
        folder=trial.folder, error=error,
    )  # fmt: skip
    row.update({k: v for k, v in measures.items() if k in row})
    return row


def write_results(sweep_dir: Path, trials: Sequence[Trial], rows: Sequence[dict]) -> None:
    """``results.csv``, ``results.json`` and ``summary.png``, each written atomically."""
    from warehouse_phys.viz.figures import save_figure
    from warehouse_phys.viz.plots import sweep_figure

    table = io.StringIO()
    writer = csv.DictWriter(table, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(sweep_dir / RESULTS_CSV, table.getvalue())
    atomic_write_text(sweep_dir / RESULTS_JSON, json.dumps({"trials": list(rows)}, indent=2) + "\n")
    configurations: dict[str, list[dict[str, Any]]] = {}
    for trial, row in zip(trials, rows, strict=True):
        configurations.setdefault(trial.configuration, [])
        if row["status"] == "done":
            summary = json.loads((sweep_dir / trial.folder / SUMMARY_FILE).read_text())
            configurations[trial.configuration].append(
                {"fraction_optimal": row["fraction_optimal"],
                 "learning_curve": summary["learning_curve"]}
            )  # fmt: skip
    figure = sweep_figure(configurations, f"{len(rows)} trials, {sweep_dir.name}")
    save_figure(figure, sweep_dir / SUMMARY_PNG)
