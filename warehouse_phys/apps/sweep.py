"""``python -m warehouse_phys.sweep``: a grid of training runs on Ray Tune, one table of results.

Every combination of the environments, floors, learning rates, discounts,
episode counts and seeds given is one trial. Each trial trains with
:mod:`warehouse_phys.rl.qlearning` inside a Ray worker and writes its own run
folder (table, learning curve, summary; ``--gif`` adds the episode's GIF) under
``<out>/runs/``, through the same code as ``python -m warehouse_phys.train``.
The sweep then writes ``results.csv`` and ``results.json`` (a row per trial)
and ``summary.png`` (each configuration's spread over its seeds).

    python -m warehouse_phys.sweep --env grid phys --seeds 4
    python -m warehouse_phys.sweep --layout default maze --seeds 0-7 --alpha 0.5 0.9
    python -m warehouse_phys.sweep --address auto ...   # on a running Ray cluster

Running the same command again with the same ``--out`` resumes: a trial whose
folder holds a complete run of its configuration is not trained again, and the
tables cover the whole grid. A folder holding anything but a sweep's own files
is refused, as ``train --out`` refuses a folder of other files. A failed trial
is recorded with its error while the others go on; the command then exits with
status 1 and says how many failed. Ray Tune comes with the ``ray`` extra
(``pip install "warehouse_phys[ray]"``); without it the command exits with
status 2 and says so.

Nothing waits for resources that cannot come: a grid of more than
:data:`MAX_TRIALS` trials and ``--cpus-per-trial`` beyond the machine's (or the
cluster's) CPUs are refused before anything is built, and an ``--address`` where
no Ray cluster answers fails within seconds, each in one line. On SIGINT or
SIGTERM the Ray processes the sweep started are shut down before it exits.

A killed driver (SIGKILL) cannot shut Ray down: its workers, trials' included,
live on for seconds, Ray's agents for a minute. Running the sweep again in the
same folder at once is safe all the same:

- The driver holds ``sweep.lock`` in the sweep folder (``flock``) and writes its
  pid and a token new to this run there. A sweep into the folder of a live one
  is refused, naming its pid; a killed driver's lock, freed by the operating
  system, is taken over (:func:`take_sweep_lock`).
- Each trial carries its run's token and compares it with the lock file's once
  it holds its run folder's lock, before it removes or writes anything there: a
  worker of an earlier run stops, the folder untouched (:class:`TrialFolder`).
- The driver reads a finished trial's folder under a shared lock, so a folder
  that a lingering worker holds is not finished but run again, the new worker
  waiting up to :data:`FOLDER_WAIT` for the old one to let go.
- A trial is finished only if its ``qtable.npz`` loads
  (:func:`~warehouse_phys.rl.qtable_file.load_q_table`) and is its configuration's.

One command line over Ray Tune: its length is Ray's set-up and shut-down, the trials
and the results tables.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import fcntl
import importlib.util
import io
import itertools
import json
import logging
import os
import signal
import socket
import sys
import threading
import time
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from warehouse_phys.apps.cli import (
    ArgumentParser,
    UsageError,
    bounded_int,
    floor_from_layout,
)
from warehouse_phys.apps.interrupts import Terminated
from warehouse_phys.apps.runs import ENVIRONMENTS, RUN_FILES, SUMMARY_FILE, TABLE_FILE, Floor
from warehouse_phys.files.atomic import TEMPORARY_PREFIX, TEMPORARY_SUFFIX, atomic_write_text
from warehouse_phys.files.runfolder import RunFolder, RunFolderError
from warehouse_phys.rl.qlearning import QLearningConfig, check_training_memory
from warehouse_phys.world.grid import DEFAULT_COLS, DEFAULT_ROWS, MAX_SIDE, MIN_SIDE
from warehouse_phys.world.layouts import PRESETS

PROG = "python -m warehouse_phys.sweep"
INSTALL_RAY = 'pip install "warehouse_phys[ray]"'
DEFAULT_SWEEPS_DIR = Path("sweeps")
#: The floor named ``default`` in ``--layout``: the plain floor of ``--rows`` x ``--cols``.
DEFAULT_FLOOR = "default"
RESULTS_CSV, RESULTS_JSON, SUMMARY_PNG = "results.csv", "results.json", "summary.png"
#: The driver's lock file in the sweep folder: its pid and its run's token.
LOCK_FILE = "sweep.lock"
#: What a sweep folder may hold: the sweep's tables, figure and lock, its run folders and Tune's.
SWEEP_ENTRIES = frozenset({RESULTS_CSV, RESULTS_JSON, SUMMARY_PNG, LOCK_FILE, "runs", "tune"})
#: Most seeds in one ``--seeds``: each is a trial (times the other settings) and a folder.
MAX_SEEDS = 10_000
#: Most trials in one sweep [trials]: each is a Tune trial, a run folder and a row.
MAX_TRIALS = 10_000
#: How long a trial waits for its run folder while another process holds it (a
#: lingering worker of a killed sweep, which Ray ends within a minute or so) [s].
FOLDER_WAIT = 120.0
#: How long ``--address host:port`` may take to accept a connection [s].
CONNECT_TIMEOUT = 5.0
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
        token of the sweep's run (see :func:`take_sweep_lock`), which the worker checks."""
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


class SupersededError(RuntimeError):
    """A trial of an earlier run of the sweep, whose folder a newer run owns now."""


class TrialFolder(RunFolder):
    """A trial's run folder: waits for it while another process holds it, and is
    touched only while ``run`` is the token in ``lock`` (the sweep's current run).

    Without ``run``, no token is checked (a trial run outside a sweep).
    """

    def __init__(self, path: str | os.PathLike[str], lock: str, run: str | None) -> None:
        super().__init__(path, RUN_FILES, overwrite=True)  # a failed try's files go
        self.lock, self.run = lock, run

    def open(self) -> RunFolder:
        """:meth:`RunFolder.open`, retried for up to :data:`FOLDER_WAIT` while another
        process holds the folder's lock.

        Raises:
            SupersededError: if the sweep has moved on to a newer run.
            RunFolderError, RunWriteError: as :meth:`RunFolder.open`.
        """
        deadline = time.monotonic() + FOLDER_WAIT
        while True:
            try:
                return super().open()
            except RunFolderError:
                if time.monotonic() > deadline or not _held_by_another(self.path):
                    raise
            time.sleep(0.5)

    def _clean(self) -> None:
        # Here the folder is locked and nothing is removed yet: the one place where the
        # check cannot race with a newer run's driver, which reads the folder under a lock.
        if self.run is not None:
            try:
                current = Path(self.lock).read_text(encoding="utf-8").strip()
            except OSError:
                current = ""
            if current != self.run:
                raise SupersededError(
                    f"{self.path}: the sweep's run {self.run!r} is over; a newer run "
                    f"({current or 'none'!r}) owns the folder"
                )
        super()._clean()


def _held_by_another(folder: Path) -> bool:
    """Whether a process holds the lock of ``folder`` (a run writing it)."""
    with _shared_lock(folder) as taken:
        return taken is False


@contextmanager
def _shared_lock(folder: Path) -> Iterator[bool | None]:
    """A shared lock on ``folder`` while the block runs, which a run writing the folder
    (it locks it exclusively) excludes: yields True when taken, False when such a run
    holds the folder, ``None`` when the folder cannot be opened or locked."""
    try:
        handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        yield None
        return
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            taken: bool | None = False
        except OSError:
            taken = None
        else:
            taken = True
        yield taken
    finally:
        os.close(handle)  # releases the lock too


def run_trial(job: dict[str, Any]) -> dict[str, Any]:
    """Train one trial in the current process and write its run folder: Tune's trainable.

    Imports what it needs here, in the worker; the environments are made with
    ``warehouse_phys:`` ids, which register the package in any process.
    Returns the trial's row of the results table.
    """
    from warehouse_phys.apps.runs import train_run

    floor_fields = dict(job["floor"])
    if floor_fields.get("layout") is not None:
        floor_fields["layout"] = tuple(floor_fields["layout"])
    floor = Floor(**floor_fields)
    config = QLearningConfig(**job["config"])
    folder = TrialFolder(job["folder"], job["lock"], job.get("run"))
    with folder:
        outcome = train_run(folder, floor, job["env"], config, gif=job["gif"])
    return _measures(outcome.summary)


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


# ----------------------------------------------------------------- the grid
def build_parser() -> argparse.ArgumentParser:
    """The command line's argument parser."""
    defaults = QLearningConfig()
    parser = ArgumentParser(
        prog=PROG,
        description="Train a grid of Q-learning runs on Ray Tune and tabulate the results.",
    )
    parser.add_argument(
        "--env", nargs="+", choices=sorted(ENVIRONMENTS), default=["grid"],
        help="environments: grid, phys or both (default grid)",
    )  # fmt: skip
    parser.add_argument(
        "--layout", nargs="+", metavar="NAME_OR_FILE", default=[DEFAULT_FLOOR],
        help=f"floors: '{DEFAULT_FLOOR}' (the --rows x --cols floor), presets "
        f"({', '.join(PRESETS)}) or layout files (default: {DEFAULT_FLOOR})",
    )  # fmt: skip
    side = bounded_int(MIN_SIDE, f"{MIN_SIDE} to {MAX_SIDE}", MAX_SIDE)
    parser.add_argument(
        "--rows", type=side, default=DEFAULT_ROWS,
        help=f"rows of the default floor ({DEFAULT_ROWS})",
    )  # fmt: skip
    parser.add_argument(
        "--cols", type=side, default=DEFAULT_COLS,
        help=f"columns of the default floor ({DEFAULT_COLS})",
    )  # fmt: skip
    parser.add_argument(
        "--seeds", type=_seeds, default=[0, 1, 2, 3], metavar="N_OR_A-B",
        help="seeds: a count N (0..N-1) or an inclusive range A-B (default 4)",
    )  # fmt: skip
    parser.add_argument(
        "--alpha", nargs="+", type=float, default=[defaults.alpha],
        help=f"learning rates in (0, 1] (default {defaults.alpha})",
    )  # fmt: skip
    parser.add_argument(
        "--gamma", nargs="+", type=float, default=[defaults.gamma],
        help=f"discounts in [0, 1] (default {defaults.gamma})",
    )  # fmt: skip
    parser.add_argument(
        "--episodes", nargs="+", type=bounded_int(1, "a positive number of episodes"),
        help="training episodes (default: each preset's own, 1000 on other floors)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, help="the sweep folder (default sweeps/<time>)")
    parser.add_argument(
        "--address", help="the address of a running Ray cluster (default: start a local one)"
    )
    parser.add_argument(
        "--cpus-per-trial", type=bounded_int(1, "a positive number of CPUs"), default=1,
        help="CPUs Ray reserves for each trial (default 1)",
    )  # fmt: skip
    parser.add_argument(
        "--max-concurrent", type=bounded_int(1, "a positive number of trials"),
        help="most trials at once (default: as many as the CPUs allow)",
    )  # fmt: skip
    parser.add_argument("--gif", action="store_true", help="write each run's episode.gif too")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
    return parser


def _seeds(text: str) -> list[int]:
    """``N`` (0..N-1) or ``A-B`` (A..B inclusive)."""
    try:
        if "-" in text:
            first, last = (int(part) for part in text.split("-", 1))
        else:
            first, last = 0, int(text) - 1
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a count N or a range A-B, got {text!r}"
        ) from None
    if first < 0 or last < first:
        raise argparse.ArgumentTypeError(f"expected a count N >= 1 or a range A-B, got {text!r}")
    if last - first >= MAX_SEEDS:
        raise argparse.ArgumentTypeError(f"expected at most {MAX_SEEDS} seeds, got {text!r}")
    return list(range(first, last + 1))


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


# ----------------------------------------------------------------- results
def finished_row(trial: Trial, sweep_dir: Path) -> dict[str, Any] | None:
    """The row of a trial whose folder already holds a complete run of its configuration:
    a summary of its settings and a table that loads and is that run's; ``None`` otherwise,
    and while another process (a lingering worker) holds the folder."""
    from warehouse_phys.rl.qtable_file import load_q_table

    folder = sweep_dir / trial.folder
    config = {"episodes": trial.episodes, "alpha": trial.alpha, "gamma": trial.gamma,
              "seed": trial.seed}  # fmt: skip
    env_id = trial.floor.env_id(trial.env)
    with _shared_lock(folder) as taken:  # excludes a worker writing the folder
        if not taken:
            return None
        try:
            summary = json.loads((folder / SUMMARY_FILE).read_text(encoding="utf-8"))
            _, metadata = load_q_table(folder / TABLE_FILE)  # a truncated table raises
        except (OSError, ValueError):  # QTableError is a ValueError
            return None
        try:
            same = (
                summary["config"] == config
                and summary["env_id"] == metadata["env_id"] == env_id
                and {name: metadata[name] for name in config} == config
            )
            return _row(trial, "done", _measures(summary)) if same else None
        except (KeyError, TypeError):
            return None


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
    from warehouse_phys.viz.plots import save_figure, sweep_figure

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


def check_sweep_folder(sweep_dir: Path) -> None:
    """Refuse a sweep folder that holds anything but a sweep's own files.

    A new or empty folder starts a sweep, an earlier sweep's folder resumes it;
    a folder of other files is never written into, as with ``train --out``.

    Raises:
        UsageError: naming the folder and a few of the files that are not a sweep's.
    """
    try:
        names = sorted(entry.name for entry in os.scandir(sweep_dir))
    except FileNotFoundError:
        return
    except NotADirectoryError:
        raise UsageError(f"--out {sweep_dir} exists and is not a folder") from None
    except OSError as error:
        raise UsageError(f"--out {sweep_dir}: cannot read it: {error.strerror}") from None
    temporary = tuple(f"{TEMPORARY_PREFIX}{name}." for name in SWEEP_ENTRIES)
    foreign = [
        name
        for name in names
        if name not in SWEEP_ENTRIES
        and not (name.startswith(temporary) and name.endswith(TEMPORARY_SUFFIX))
    ]
    if foreign:
        shown = ", ".join(foreign[:3]) + (
            f" and {len(foreign) - 3} more" if len(foreign) > 3 else ""
        )
        raise UsageError(
            f"--out {sweep_dir} holds files that are not a sweep's ({shown}); choose a new or "
            "empty folder, or an earlier sweep's folder to resume it"
        )


def check_cpus_per_trial(cpus_per_trial: int, available: float, where: str) -> None:
    """Refuse a trial that needs more CPUs than ``where`` has: Ray would wait for ever.

    Raises:
        UsageError: naming the CPUs available.
    """
    if cpus_per_trial > available:
        raise UsageError(
            f"--cpus-per-trial {cpus_per_trial}: {where} has {available:g} CPUs, so no trial "
            "could ever start"
        )


# ------------------------------------------------------------------- running
class RayUnavailableError(Exception):
    """No Ray cluster could be reached or started; the message says why, in one line."""


#: Set once SIGTERM arrives: Tune may re-raise the interrupt as a plain KeyboardInterrupt.
_terminated = threading.Event()


def _terminate(signum: int, frame: object) -> None:
    _terminated.set()
    raise Terminated  # so that the Ray processes started are shut down


def check_address(address: str) -> None:
    """Fail at once where nothing listens at ``address`` (``host:port`` or ``ray://host:port``).

    Ray itself retries an address for minutes. ``auto`` and ``local`` are left to Ray.

    Raises:
        RayUnavailableError: if no connection opens within :data:`CONNECT_TIMEOUT`.
    """
    if address in ("auto", "local"):
        return
    host, colon, port = address.removeprefix("ray://").rpartition(":")
    if not colon or not port.isdigit() or not host:
        raise RayUnavailableError(
            f"--address {address}: expected host:port, ray://host:port, auto or local"
        )
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except (OSError, OverflowError) as error:
        reason = getattr(error, "strerror", None) or str(error) or type(error).__name__
        raise RayUnavailableError(
            f"--address {address}: no Ray cluster answers: {reason}"
        ) from None


@contextmanager
def ray_session(address: str | None, cpus_per_trial: int) -> Iterator[None]:
    """Ray for the sweep: connected to ``address``, or a local Ray started here.

    A Ray this call started is shut down when the block ends, however it ends:
    SIGINT and (while the block lasts) SIGTERM interrupt it as
    ``KeyboardInterrupt``. A Ray already running in the process is used as it is.

    Raises:
        RayUnavailableError: if no cluster answers at ``address``, or Ray cannot start.
        UsageError: if the cluster has fewer CPUs than ``cpus_per_trial``.
    """
    import ray

    if ray.is_initialized():
        yield
        return
    if address is not None:
        check_address(address)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if main_thread else None
    options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                               "logging_level": logging.ERROR}  # fmt: skip
    try:
        if main_thread:
            signal.signal(signal.SIGTERM, _terminate)
        try:
            if address is None:
                ray.init(num_cpus=os.cpu_count() or 1, **options)
            else:
                ray.init(address=address, **options)
        except (ConnectionError, RuntimeError, ValueError) as error:
            lines = str(error).strip().splitlines() or [type(error).__name__]
            where = "cannot start a local Ray" if address is None else f"--address {address}"
            raise RayUnavailableError(f"{where}: {lines[0]}") from None
        if main_thread:
            signal.signal(signal.SIGTERM, _terminate)  # ray.init installs its own
        if address is not None:
            cpus = ray.cluster_resources().get("CPU", 0)
            check_cpus_per_trial(cpus_per_trial, cpus, f"the cluster at {address}")
        yield
    finally:
        ray.shutdown()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def run_on_tune(
    jobs: Sequence[dict[str, Any]],
    sweep_dir: Path,
    *,
    address: str | None,
    cpus_per_trial: int,
    max_concurrent: int | None,
    quiet: bool,
) -> dict[str, dict[str, Any] | BaseException]:
    """Run ``jobs`` as one Ray Tune experiment; each trial's measures, or its error, by name."""
    # Tune's own console output (a configuration box, TensorBoard hints) gives way to
    # one line per finished trial (the Progress callback below).
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    os.environ.setdefault("TUNE_DISABLE_AUTO_CALLBACK_LOGGERS", "1")
    # Ctrl-C interrupts at once (and ray_session shuts Ray down) rather than waiting
    # for Tune to stop the trials gracefully.
    os.environ.setdefault("TUNE_DISABLE_SIGINT_HANDLER", "1")
    from ray import tune

    total = len(jobs)

    class Progress(tune.Callback):
        """One line per finished trial: what matters of Tune's reporting."""

        def __init__(self) -> None:
            self.done = 0

        def on_trial_complete(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
            self._report(trial, "done")

        def on_trial_error(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
            self._report(trial, "FAILED")

        def _report(self, trial: Any, status: str) -> None:
            self.done += 1
            if not quiet:
                print(f"[{self.done}/{total}] {trial.config['job']['name']}: {status}", flush=True)

    with ray_session(address, cpus_per_trial):
        trainable = tune.with_resources(run_trial_job, {"cpu": cpus_per_trial})
        tuner = tune.Tuner(
            trainable,
            param_space={"job": tune.grid_search(list(jobs))},
            tune_config=tune.TuneConfig(max_concurrent_trials=max_concurrent),
            run_config=tune.RunConfig(
                name="tune",
                storage_path=str((sweep_dir / "tune").resolve()),
                verbose=0,
                callbacks=[Progress()],
                failure_config=tune.FailureConfig(max_failures=0),
            ),
        )
        logging.getLogger("ray").setLevel(logging.CRITICAL)
        grid = tuner.fit()
    outcomes: dict[str, dict[str, Any] | BaseException] = {}
    for result in grid:
        name = result.config["job"]["name"]
        outcomes[name] = result.error if result.error is not None else dict(result.metrics)
    return outcomes


def run_trial_job(config: dict[str, Any]) -> dict[str, Any]:
    """Tune's trainable: the trial in ``config["job"]`` (see :func:`run_trial`)."""
    return run_trial(config["job"])


def _error_line(error: BaseException) -> str:
    """The root cause of a trial's error, in one line."""
    cause = getattr(error, "cause", None) or error
    text = str(cause).strip().splitlines()
    return f"{type(cause).__name__}: {text[-1] if text else ''}".strip()


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
        settings = settings_from_args(args)  # refuses a grid too big before building it
        try:
            if (
                importlib.util.find_spec("ray") is None
                or importlib.util.find_spec("ray.tune") is None
            ):
                raise ImportError("ray")
        except ImportError:
            raise UsageError(
                f"the sweep runs on Ray Tune, which is not installed: {INSTALL_RAY}"
            ) from None
        if args.address is None:
            check_cpus_per_trial(args.cpus_per_trial, os.cpu_count() or 1, "this machine")
        else:
            check_address(args.address)
        trials = expand_trials(settings, args.seeds)
        sweep_dir = args.out or DEFAULT_SWEEPS_DIR / time.strftime("%Y%m%d-%H%M%S")
        check_sweep_folder(sweep_dir)
        return _sweep(args, trials, sweep_dir)
    except UsageError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except RayUnavailableError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as interrupt:
        terminated = isinstance(interrupt, Terminated) or _terminated.is_set()
        print(f"{PROG}: {'terminated' if terminated else 'interrupted'}; finished trials keep "
              "their folders: run the same command again to resume", file=sys.stderr)  # fmt: skip
        return 128 + (signal.SIGTERM if terminated else signal.SIGINT)


def take_sweep_lock(sweep_dir: Path) -> tuple[int, str]:
    """Lock the sweep folder for this driver: ``(handle, token)``; closing the handle
    (or the process ending, however it ends) releases the lock.

    The lock file then holds this process's pid and a token new to this run,
    which the run's trials carry (see the module's docstring). A lock left by a
    killed driver is free, and taken over.

    Raises:
        UsageError: naming the pid of the live sweep that holds the folder.
        OSError: if the lock file cannot be created or written.
    """
    handle = os.open(sweep_dir / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        token = f"{os.getpid()} {uuid.uuid4().hex}"
        os.ftruncate(handle, 0)  # rewritten in place: the lock is this file's, not its name's
        os.pwrite(handle, f"{token}\n".encode(), 0)
        os.fsync(handle)
    except BlockingIOError:
        holder = os.pread(handle, 100, 0).decode("utf-8", "replace").split()
        os.close(handle)
        raise UsageError(
            f"--out {sweep_dir} is in use by the sweep of process "
            f"{holder[0] if holder else 'unknown'}; wait for it to end or choose another folder"
        ) from None
    except BaseException:
        os.close(handle)
        raise
    return handle, token


def _sweep(args: argparse.Namespace, trials: list[Trial], sweep_dir: Path) -> int:
    created = not sweep_dir.exists()
    try:
        sweep_dir.mkdir(parents=True, exist_ok=True)
        handle, run = take_sweep_lock(sweep_dir)
    except OSError as error:
        print(f"{PROG}: error: cannot write {sweep_dir}: {error.strerror}", file=sys.stderr)
        return 1
    try:
        return _run_sweep(args, trials, sweep_dir, run)
    except (RayUnavailableError, UsageError):
        if created:  # no Ray, no trial: leave no empty folder behind
            with contextlib.suppress(OSError):
                (sweep_dir / LOCK_FILE).unlink()
                sweep_dir.rmdir()
        raise
    finally:
        os.close(handle)


def _run_sweep(args: argparse.Namespace, trials: list[Trial], sweep_dir: Path, run: str) -> int:
    rows: dict[str, dict[str, Any]] = {}
    for trial in trials:
        row = finished_row(trial, sweep_dir)
        if row is not None:
            rows[trial.name] = row
    pending = [trial for trial in trials if trial.name not in rows]
    if not args.quiet:
        print(f"{len(trials)} trials in {sweep_dir}: {len(trials) - len(pending)} already "
              f"finished, {len(pending)} to run")  # fmt: skip
    started = time.perf_counter()
    if pending:
        outcomes = run_on_tune(
            [trial.to_job(sweep_dir, args.gif, run) for trial in pending],
            sweep_dir,
            address=args.address,
            cpus_per_trial=args.cpus_per_trial,
            max_concurrent=args.max_concurrent,
            quiet=args.quiet,
        )
        for trial in pending:
            outcome = outcomes.get(trial.name)
            if isinstance(outcome, dict):
                rows[trial.name] = _row(trial, "done", outcome)
            else:
                error = "not run" if outcome is None else _error_line(outcome)
                rows[trial.name] = _row(trial, "failed", {}, error)
    seconds = time.perf_counter() - started
    ordered = [rows[trial.name] for trial in trials]
    write_results(sweep_dir, trials, ordered)
    failed = [row for row in ordered if row["status"] != "done"]
    if not args.quiet:
        ran = [rows[trial.name] for trial in pending]
        trained = sum(row["training_seconds"] or 0 for row in ran if row["status"] == "done")
        print(
            f"ran {len(pending)} trial{'' if len(pending) == 1 else 's'} in {seconds:.1f} s "
            f"(their training: {trained:.1f} s in all); wrote {sweep_dir / RESULTS_CSV}, "
            f"{RESULTS_JSON} and {SUMMARY_PNG}"
        )
    if failed:
        print(f"{PROG}: {len(failed)} of {len(trials)} trials failed; see "
              f"{sweep_dir / RESULTS_CSV}", file=sys.stderr)  # fmt: skip
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
