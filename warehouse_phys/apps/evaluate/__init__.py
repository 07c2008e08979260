"""``python -m warehouse_phys.evaluate``: planners x LoRR instances x seeds as one suite,
each run a Ray task, one table and one figure.

::

    python -m warehouse_phys.evaluate --planners guided --steps 1000 \\
        --instances ../shared/lorr/2024-main-warehouse/WAREHOUSE.json
    python -m warehouse_phys.evaluate --archive ~/.cache/lorr-archive/archive --rounds 2023,2024 \\
        --planners guided --out evaluations/main-rounds
    python -m warehouse_phys.evaluate --address host:6379 ...   # on a running Ray cluster

Each planner (a name of :data:`~warehouse_phys.rl.fleet_planners.PLANNERS`) plays each
instance with each seed, as one Ray task in a process of its own (a local Ray by default,
``--address`` for a cluster; the Ray session is the sweep's,
:func:`~warehouse_phys.apps.sweep.on_ray.ray_session`). ``--archive`` names a clone of
the competition's Benchmark-Archive (kept outside this repository): each run is then set
beside the instance's best-known solution, and ``--rounds`` adds every main-round
instance of those years, each for its own simulation time. Every finished run writes its
row to ``<out>/runs/`` (:mod:`~warehouse_phys.apps.evaluate.suite`); running the same
command again with the same ``--out`` resumes, running only what is not finished, and a
run killed half way goes on from the state it saved last (every ``--checkpoint-minutes``,
10 by default, 0 for none: :mod:`~warehouse_phys.apps.evaluate.checkpoints`; on a
cluster, only where its nodes share the folder). The
suite then writes ``results.csv``, ``results.md`` and ``results.png``
(:mod:`~warehouse_phys.apps.evaluate.report`).

A refused argument or input file is one line and exit status 2 (so is a machine without
Ray: ``pip install "warehouse_phys[ray]"``); runs that failed are in
the table with their error and the status is 1; Ctrl-C or SIGTERM stops the suite with
finished runs kept (130, 143). Two suites into one folder at once are refused.
"""

from __future__ import annotations

import argparse
import fcntl
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
    add_guidance_argument,
    bounded_int,
)
from warehouse_phys.apps.evaluate.best_known import (
    DEFAULT_STEPS,
    best_known_for,
    main_round_instances,
    read_best_known,
)
from warehouse_phys.apps.evaluate.checkpoints import checkpoint_path
from warehouse_phys.apps.evaluate.report import RESULTS_CSV, write_results
from warehouse_phys.apps.evaluate.suite import RUNS_DIR, Job, finished_rows, run_job, write_row
from warehouse_phys.apps.interrupts import Terminated, stops_on_sigterm
from warehouse_phys.apps.sweep import INSTALL_RAY
from warehouse_phys.apps.sweep.on_ray import RayUnavailableError, check_address, ray_session
from warehouse_phys.files.atomic import temporary_files
from warehouse_phys.lorr.station_cap import STATION_CAP

PROG = "python -m warehouse_phys.evaluate"
#: Where suites go without ``--out``.
DEFAULT_DIR = Path("evaluations")
LOCK_FILE = "evaluate.lock"
#: Most runs one suite may hold.
MAX_RUNS = 10_000


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument("--instances", nargs="+", type=Path, default=[], metavar="JSON",
                        help="LoRR instance files")  # fmt: skip
    parser.add_argument("--archive", type=Path, metavar="DIR",
                        help="a clone of the Benchmark-Archive: best-known solutions")  # fmt: skip
    parser.add_argument("--rounds", default="", metavar="YEARS",
                        help="with --archive: these years' main rounds (2023,2024)")  # fmt: skip
    parser.add_argument("--planners", default="guided", help="planner names, comma-separated")
    parser.add_argument("--seeds", default="0", help="seeds: 0,1,2 or 0-2 (default 0)")
    parser.add_argument("--steps", type=bounded_int(1, "a positive number of steps"),
                        help="steps a run (default: the archive's simulation time)")  # fmt: skip
    parser.add_argument("--moves", choices=("rotate", "grid"), default="rotate",
                        help="robot model (default rotate, LoRR's turning robots)")  # fmt: skip
    parser.add_argument("--scheduler", help="a 2024 instance's scheduler: nearest, makespan, "
                        "assignment[=W], rematch[=W] (the assignment, robots on their way "
                        "to a task not opened paired again), rematch-capped[=W] (the same, "
                        f"at most {STATION_CAP} robots on their way to one station) or "
                        "rematch-backlog[=W] (that cap, grown at a station with more open "
                        "tasks than the mean)")  # fmt: skip
    add_guidance_argument(parser)
    parser.add_argument("--out", type=Path, help="the suite's folder (evaluations/<time>)")
    parser.add_argument("--address", help="a Ray cluster's host:port (default: a local Ray)")
    parser.add_argument("--cpus-per-run", type=bounded_int(1, "a positive number of CPUs"),
                        default=1, help="CPUs Ray gives each run (default 1)")  # fmt: skip
    parser.add_argument("--checkpoint-minutes", default=10,
                        type=bounded_int(0, "a number of minutes (0: none)"),
                        help="save each run's state this often, to go on from when the "
                             "suite runs again (default 10; 0: save none)")  # fmt: skip
    parser.add_argument("--quiet", action="store_true", help="no line per finished run")
    return parser


def jobs_from_args(args: argparse.Namespace) -> list[Job]:
    """Every run the arguments ask for, checked before anything runs.

    Raises:
        UsageError: naming the argument or file at fault.
    """
    from warehouse_phys.lorr.instances import read_instance
    from warehouse_phys.lorr.scheduling_assignment import scheduler_for
    from warehouse_phys.rl.fleet_planners import PLANNERS, planner_policy
    from warehouse_phys.world.grid import WarehouseGrid

    planners = [name for name in args.planners.split(",") if name]
    for name in planners:
        if name not in PLANNERS:
            raise UsageError(f"--planners: unknown planner {name!r}; known: {', '.join(PLANNERS)}")
        try:
            planner_policy(name, **({} if name == "pibt" else args.guidance))
        except (TypeError, ValueError) as error:
            raise UsageError(f"--guidance: {error}") from None
    if args.scheduler is not None:
        try:
            scheduler_for(args.scheduler, WarehouseGrid(2, 2))  # the name alone
        except ValueError as error:
            raise UsageError(f"--scheduler: {error}") from None
    seeds = parse_seeds(args.seeds)
    table, listed = {}, [(path, None) for path in args.instances]
    if args.archive is not None:
        try:
            table = read_best_known(args.archive)
            for year in [y for y in args.rounds.split(",") if y]:
                listed += main_round_instances(args.archive, int(year))
        except ValueError as error:
            raise UsageError(f"--archive/--rounds: {error}") from None
    elif args.rounds:
        raise UsageError("--rounds needs --archive")
    if not listed or not planners:
        raise UsageError("nothing to run: give --instances, or --archive with --rounds")
    jobs = []
    for path, archive_steps in listed:
        try:
            name = read_instance(path).name
        except (OSError, ValueError) as error:
            raise UsageError(f"--instances: {error}") from None
        best = best_known_for(name, table)
        steps = args.steps or archive_steps or (best.steps if best else DEFAULT_STEPS)
        for planner in planners:
            for seed in seeds:
                jobs.append(Job(planner, str(Path(path).resolve()), seed, steps, args.moves,
                                args.scheduler, {} if planner == "pibt" else args.guidance,
                                None if best is None else (best.count, best.steps)))  # fmt: skip
    if len(jobs) > MAX_RUNS:
        raise UsageError(f"{len(jobs):,} runs: at most {MAX_RUNS:,} in one suite")
    return jobs


def parse_seeds(text: str) -> list[int]:
    """``0,1,2`` or ``0-2`` (or both, ``0-2,7``) as a list of seeds >= 0.

    Raises:
        UsageError: for anything else.
    """
    seeds: list[int] = []
    for part in text.split(","):
        first, dash, last = part.strip().partition("-")
        if not first.isdigit() or (dash and not last.isdigit()):
            raise UsageError(f"--seeds: expected seeds such as 0,1,2 or 0-2, got {text!r}")
        seeds += list(range(int(first), int(last if dash else first) + 1))
    return list(dict.fromkeys(seeds))


@stops_on_sigterm
def main(argv: list[str] | None = None) -> int:
    """Run the command line; the exit status (the module's docstring)."""
    try:
        args = build_parser().parse_args(argv)
        jobs = jobs_from_args(args)
        if importlib.util.find_spec("ray") is None:  # before its folder is made
            raise UsageError(f"each run is a task on Ray, which is not installed: {INSTALL_RAY}")
        if args.address is not None:
            check_address(args.address)
        out = args.out or DEFAULT_DIR / time.strftime("%Y%m%d-%H%M%S")
        return _run_suite(args, jobs, out)
    except UsageError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except RayUnavailableError as error:
        refused = type(error).__name__ == "AddressRefusedError"
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2 if refused else 1
    except KeyboardInterrupt as interrupt:
        terminated = isinstance(interrupt, Terminated)
        print(f"{PROG}: {'terminated' if terminated else 'interrupted'}; finished runs are kept "
              "and the others as last saved (--checkpoint-minutes): run the same command "
              "again to resume", file=sys.stderr)  # fmt: skip
        return 128 + (signal.SIGTERM if terminated else signal.SIGINT)


def _run_suite(args: argparse.Namespace, jobs: list[Job], out: Path) -> int:
    try:
        out.mkdir(parents=True, exist_ok=True)
        handle = os.open(out / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as error:
        raise UsageError(f"--out {out}: cannot be written ({error.strerror})") from None
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise UsageError(f"--out {out}: another suite is running in it") from None
        rows = finished_rows(out, jobs)
        for job in jobs:
            saved = checkpoint_path(out, RUNS_DIR, job.name)
            if job.name in rows:  # left by a suite stopped just after the row
                saved.unlink(missing_ok=True)
            if saved.parent.is_dir():  # a checkpoint's write cut short by a kill
                for left in temporary_files(saved.parent, saved.name):
                    left.unlink(missing_ok=True)
        pending = [job for job in jobs if job.name not in rows]
        if not args.quiet:
            print(f"{len(jobs)} runs in {out}: {len(rows)} already finished, {len(pending)} to run",
                  flush=True)  # fmt: skip
        if pending:
            rows |= _run_on_ray(pending, out, args)
        ordered = [rows.get(job.name) or {**_describe(job), "error": "not run"} for job in jobs]
        write_results(out, ordered, title=f"{', '.join(dict.fromkeys(j.planner for j in jobs))}, "
                                          f"{args.moves} robots")  # fmt: skip
        failed = [row for row in ordered if row.get("error")]
        if not args.quiet:
            print(f"wrote {out / RESULTS_CSV}, results.md and results.png")
        if failed:
            print(f"{PROG}: {len(failed)} of {len(jobs)} runs failed; see {out / RESULTS_CSV}",
                  file=sys.stderr)  # fmt: skip
            return 1
        return 0
    finally:
        os.close(handle)


def _describe(job: Job) -> dict[str, Any]:
    return {"name": job.name, "instance": Path(job.instance).stem, "planner": job.planner,
            "seed": job.seed, "steps": job.steps}  # fmt: skip


def _run_on_ray(pending: list[Job], out: Path, args: argparse.Namespace) -> dict[str, dict]:
    """Run ``pending`` as Ray tasks, each in a fresh worker process; write each finished
    row as it comes; the rows (failed runs with their error) by job name."""
    import ray

    rows: dict[str, dict] = {}
    with ray_session(args.address, args.cpus_per_run):
        remote = ray.remote(num_cpus=args.cpus_per_run, max_calls=1, max_retries=0)(run_job)
        # Each run goes on from the state it saved into the suite's folder, and saves its
        # own (where its worker sees the folder: a local Ray, or one the cluster shares).
        folder = str(out.resolve())
        seconds = 60.0 * args.checkpoint_minutes if args.checkpoint_minutes else None
        # A run's guide searches get the CPUs Ray gives it, not every core of the machine
        # each (runs side by side would start as many threads each at their first step).
        waiting = {remote.remote(job.to_dict(), folder, seconds, args.cpus_per_run): job
                   for job in pending}  # fmt: skip
        while waiting:
            ready, _ = ray.wait(list(waiting), num_returns=1)
            job = waiting.pop(ready[0])
            try:
                row = ray.get(ready[0])
                write_row(out, row)
                checkpoint_path(out, RUNS_DIR, job.name).unlink(missing_ok=True)
                status = f"{row['per_step']:.2f} a step"
                if row["fraction_of_best"] is not None:
                    status += f", {row['fraction_of_best']:.3f} of the best known"
            except ray.exceptions.RayError as error:
                cause = getattr(error, "cause", None) or error
                lines = str(cause).strip().splitlines() or [type(cause).__name__]
                row = {**_describe(job), "error": f"{type(cause).__name__}: {lines[-1]}"}
                status = f"FAILED: {row['error']}"
            rows[job.name] = row
            if not args.quiet:
                print(f"[{len(rows)}/{len(pending)}] {job.name}: {status}", flush=True)
    return rows
