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
:data:`~warehouse_phys.apps.sweep.trials.MAX_TRIALS` trials and ``--cpus-per-trial``
beyond the machine's (or the cluster's) CPUs are refused before anything is built, and
an ``--address`` where no Ray cluster answers fails within seconds, each in one line with
exit status 2 (a local Ray that cannot start: 1). On SIGINT or SIGTERM (exit status 130 or
143) the Ray processes the sweep started are shut down before it exits. A sweep that ends
before its tables with nothing in its new folder but its lock (no Ray, a refused
argument, an early interrupt) leaves no folder behind, ``sweeps/`` included.

A killed driver (SIGKILL) cannot shut Ray down, yet running the sweep again in the
same folder at once is safe all the same: :mod:`~warehouse_phys.apps.sweep.resume`
says how (the sweep folder's lock, each trial's token, finished trials' folders read
under a shared lock).

The command line is this module: its options, its checks and its messages, over
:mod:`~warehouse_phys.apps.sweep.trials` (the trials and the results table),
:mod:`~warehouse_phys.apps.sweep.resume` (resuming: finished trials, the folder check,
the locks) and :mod:`~warehouse_phys.apps.sweep.on_ray` (Ray and Tune).
"""

from __future__ import annotations

from warehouse_phys._starting import command_interrupts

# python -m warehouse_phys.apps.<app> imports this package before its __main__: Ctrl-C
# while it imports is the command's one line, as with the short name's.
with command_interrupts():
    import argparse
    import contextlib
    import importlib.util
    import os
    import signal
    import sys
    import time
    from pathlib import Path
    from typing import Any

    from warehouse_phys.apps.cli import (
        ArgumentParser,
        UsageError,
        bounded_int,
        warnings_in_one_line,
    )
    from warehouse_phys.apps.interrupts import Terminated, deferred, stops_on_sigterm
    from warehouse_phys.apps.runs import ENVIRONMENTS
    from warehouse_phys.apps.sweep.on_ray import (
        CONNECT_TIMEOUT,
        AddressRefusedError,
        RayUnavailableError,
        _terminated,
        check_address,
        check_cpus_per_trial,
        ray_session,
        run_on_tune,
        run_trial,
        run_trial_job,
    )
    from warehouse_phys.apps.sweep.resume import (
        FOLDER_WAIT,
        SWEEP_ENTRIES,
        SupersededError,
        TrialFolder,
        check_sweep_folder,
        finished_row,
        take_sweep_lock,
    )
    from warehouse_phys.apps.sweep.trials import (
        COLUMNS,
        DEFAULT_FLOOR,
        LOCK_FILE,
        MAX_SEEDS,
        MAX_TRIALS,
        RESULTS_CSV,
        RESULTS_JSON,
        SUMMARY_PNG,
        Setting,
        Trial,
        _row,
        expand_trials,
        settings_from_args,
        trials_from_args,
        write_results,
    )
    from warehouse_phys.files.runfolder import make_folders, remove_empty
    from warehouse_phys.rl.qlearning import QLearningConfig
    from warehouse_phys.world.grid import DEFAULT_COLS, DEFAULT_ROWS
    from warehouse_phys.world.layout_text import MAX_SIDE, MIN_SIDE
    from warehouse_phys.world.layouts import PRESETS

#: The command's names, its own and those its parts' modules define: all import from here.
__all__ = [
    "COLUMNS",
    "CONNECT_TIMEOUT",
    "DEFAULT_FLOOR",
    "DEFAULT_SWEEPS_DIR",
    "FOLDER_WAIT",
    "INSTALL_RAY",
    "LOCK_FILE",
    "MAX_SEEDS",
    "MAX_TRIALS",
    "PROG",
    "RESULTS_CSV",
    "RESULTS_JSON",
    "SUMMARY_PNG",
    "SWEEP_ENTRIES",
    "AddressRefusedError",
    "RayUnavailableError",
    "Setting",
    "SupersededError",
    "Trial",
    "TrialFolder",
    "build_parser",
    "check_address",
    "check_cpus_per_trial",
    "check_sweep_folder",
    "expand_trials",
    "finished_row",
    "main",
    "ray_session",
    "run_on_tune",
    "run_trial",
    "run_trial_job",
    "settings_from_args",
    "take_sweep_lock",
    "trials_from_args",
    "write_results",
]

PROG = "python -m warehouse_phys.sweep"
INSTALL_RAY = 'pip install "warehouse_phys[ray]"'
DEFAULT_SWEEPS_DIR = Path("sweeps")


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


@stops_on_sigterm
@warnings_in_one_line(PROG)
def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status: 0, 2 for a refused argument (an
    ``--address`` where no cluster answers included), 1 when trials failed, a local Ray
    could not start or the folder cannot be written, 130 on Ctrl-C and 143 on SIGTERM."""
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
    except (UsageError, AddressRefusedError) as error:
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


def _sweep(args: argparse.Namespace, trials: list[Trial], sweep_dir: Path) -> int:
    created: list[Path] = []  # the folders this sweep made: its own, and sweeps/ at first
    handle, ended = None, False
    try:
        try:
            with deferred():  # an interrupt waits until the folder is made and locked
                created = make_folders(sweep_dir, exist_ok=True)
                handle, run = take_sweep_lock(sweep_dir)
        except OSError as error:
            print(f"{PROG}: error: cannot write {sweep_dir}: {error.strerror}", file=sys.stderr)
            return 1
        status = _run_sweep(args, trials, sweep_dir, run)
        ended = True
        return status
    finally:
        if not ended:  # no Ray, a refused argument, an interrupt: leave no empty folder
            _remove_unused(sweep_dir, created)
        if handle is not None:
            os.close(handle)


def _remove_unused(sweep_dir: Path, created: list[Path]) -> None:
    """Remove the folders this sweep ``created`` (:func:`make_folders`) while nothing but
    its lock file is in them: a sweep that ended before any trial wrote a file."""
    if not created:
        return
    with contextlib.suppress(OSError):
        if {entry.name for entry in os.scandir(sweep_dir)} <= {LOCK_FILE}:
            (sweep_dir / LOCK_FILE).unlink(missing_ok=True)
    remove_empty(created)


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


def _error_line(error: BaseException) -> str:
    """The root cause of a trial's error, in one line."""
    cause = getattr(error, "cause", None) or error
    text = str(cause).strip().splitlines()
    return f"{type(cause).__name__}: {text[-1] if text else ''}".strip()


if __name__ == "__main__":
    sys.exit(main())
