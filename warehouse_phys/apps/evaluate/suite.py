"""An evaluation suite: planners x instances x seeds, each run one job, each finished run a
file of its own.

A :class:`Job` is one planner on one LoRR instance with one seed; :func:`run_job` plays
it in the calling process (a Ray worker, in the command) and returns its row: what it
finished (errands in 2023, tasks in 2024 and later, as the competition counts), the rate
over each third of the run, the fraction of the best known (the 2026 score's unit: tasks
a step over the best solution's tasks a step), refused moves, CPU and wall time a step
and peak memory, and how many times it went on from a checkpoint (``resumed``,
``resumed_at``; :mod:`~warehouse_phys.apps.evaluate.checkpoints`). :func:`finished_rows`
reads the rows a folder already holds, so that a suite killed half way resumes where it
stopped: a row is written whole (:func:`write_row`, atomic) or not at all, and a run cut
short goes on from its last checkpoint.
"""

from __future__ import annotations

import gc
import hashlib
import json
import resource
import statistics
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from warehouse_phys.apps.evaluate.checkpoints import (
    CHECKPOINT_SECONDS,
    Progress,
    RunState,
    checkpoint_path,
    load_checkpoint,
    save_checkpoint,
)
from warehouse_phys.files.atomic import atomic_write_text

#: The folder of a suite's finished runs, one JSON file each.
RUNS_DIR = "runs"


@dataclass(frozen=True)
class Job:
    """One run of a suite: ``planner`` (a name of
    :data:`~warehouse_phys.rl.fleet_planners.PLANNERS`) on ``instance`` (a LoRR JSON file)
    for ``steps`` steps with ``seed``; ``moves`` the robot model, ``scheduler`` a 2024
    instance's scheduler (a name of
    :func:`~warehouse_phys.lorr.scheduling_assignment.scheduler_for`; None: the fleet's
    default), ``guidance`` fields of the
    planner's guidance, ``best`` the instance's best known ``[count, steps]`` if any."""

    planner: str
    instance: str
    seed: int
    steps: int
    moves: str = "rotate"
    scheduler: str | None = None
    guidance: dict[str, Any] = field(default_factory=dict)
    best: tuple[int, int] | None = None

    @property
    def name(self) -> str:
        """A file name that differs for every different job: the instance, planner, seed
        and steps, and a digest of the rest."""
        settings = json.dumps([self.moves, self.scheduler, self.guidance, self.instance],
                              sort_keys=True)  # fmt: skip
        digest = hashlib.sha256(settings.encode()).hexdigest()[:8]
        return f"{Path(self.instance).stem}-{self.planner}-s{self.seed}-{self.steps}-{digest}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_job(
    job: dict[str, Any],
    folder: str | None = None,
    checkpoint_seconds: float | None = CHECKPOINT_SECONDS,
    threads: int | None = None,
) -> dict[str, Any]:
    """Play one job (:meth:`Job.to_dict`) in this process; its row (the module's docstring).
    Imports its floors here, so that a Ray worker pays for them only when it runs one.
    A guided planner searches on ``threads`` threads (the CPUs Ray gives the run) unless
    the job's guidance sets ``workers``; None: the guidance's default, every core the
    process may use. The plans are the same for any number.

    With the suite's ``folder`` (if this process sees it: a local Ray, or a folder the
    cluster's nodes share), the run starts from the state an earlier run of the same job
    saved there, if any (:mod:`~warehouse_phys.apps.evaluate.checkpoints`), saves its own
    every ``checkpoint_seconds`` of wall time (None: never), and removes it once it has
    played its last step. A checkpoint that cannot be written is skipped (the run goes
    on, the next one is tried an interval later, and the row says why in
    ``checkpoint_error``)."""
    spec = Job(**{**job, "best": tuple(job["best"]) if job.get("best") else None})
    described = spec.to_dict()
    checkpoint = None
    if folder is not None and Path(folder).is_dir():
        checkpoint = checkpoint_path(Path(folder), RUNS_DIR, spec.name)
    state = None if checkpoint is None else load_checkpoint(checkpoint, described)
    instance, scheduled = _instance(spec)
    if state is None:
        state = _start(spec, instance, scheduled, threads)
    else:
        state.progress.resumed_at.append(len(state.progress.done))
    gc.freeze()  # the floor's objects leave Python's full collections, as simulate does
    env, policy, progress = state.env, state.policy, state.progress
    saves = checkpoint is not None and checkpoint_seconds is not None
    saved, error = time.monotonic(), None
    while len(progress.done) < spec.steps:
        began_cpu, began_wall = time.process_time(), time.perf_counter()
        actions = policy(env, state.observations, state.infos)
        state.observations, _, _, _, state.infos = env.step(actions)
        progress.cpu.append(time.process_time() - began_cpu)
        progress.wall.append(time.perf_counter() - began_wall)
        progress.refused += sum(info["refused"] for info in state.infos.values())
        progress.done.append(env.errands.tasks_done if scheduled else env.errands.errands_done)
        left = len(progress.done) < spec.steps
        if saves and left and time.monotonic() - saved >= checkpoint_seconds:
            progress.peak_mib = _peak_mib(progress)
            try:
                save_checkpoint(checkpoint, described, state)
            except OSError as failure:  # a full disk, say: the run matters more
                error = f"{type(failure).__name__}: {failure}"
            saved = time.monotonic()
    if checkpoint is not None:
        checkpoint.unlink(missing_ok=True)
    row = job_row(spec, instance.name, env.num_robots, progress.done, progress.cpu,
                  progress.wall, progress.refused, _peak_mib(progress),
                  progress.resumed_at)  # fmt: skip
    return {**row, "checkpoint_error": error}


def _instance(spec: Job) -> tuple[Any, bool]:
    """The job's instance, and whether it is scheduled (2024 on: tasks, not errands)."""
    from warehouse_phys.lorr.instances import SCHEDULED, read_instance

    instance = read_instance(spec.instance)
    return instance, instance.assignment == SCHEDULED


def _start(spec: Job, instance: Any, scheduled: bool, threads: int | None) -> RunState:
    """The job's fleet and policy, reset: its first step not yet played."""
    from warehouse_phys.envs import lorr
    from warehouse_phys.lorr.scheduling_assignment import scheduler_for
    from warehouse_phys.rl.fleet_planners import planner_policy

    options = {}
    if spec.scheduler and scheduled:  # the scheduler of a 2024 instance (2023 assigns errands)
        options["scheduler"] = scheduler_for(spec.scheduler, instance.grid)
    env = lorr.fleet(instance, moves=spec.moves, max_cycles=spec.steps, **options)
    guidance = dict(spec.guidance)
    if threads is not None and spec.planner != "pibt":  # plain PIBT searches no guide paths
        guidance.setdefault("workers", threads)
    policy = planner_policy(spec.planner, seed=spec.seed, **guidance)
    observations, infos = env.reset(seed=spec.seed)
    return RunState(env, policy, observations, infos, Progress())


def _peak_mib(progress: Progress) -> float:
    """The run's peak memory so far, over every process it ran in [MiB]."""
    return max(progress.peak_mib, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)


def job_row(
    spec: Job,
    name: str,
    robots: int,
    done: list[int],
    cpu: list[float],
    wall: list[float],
    refused: int,
    peak_mib: float,
    resumed_at: list[int] | None = None,
) -> dict[str, Any]:
    """The row of a finished run: ``done`` is what counts, finished by each step's end;
    ``resumed_at``, the steps it went on from a checkpoint at (its times a step then come
    from more than one process)."""
    steps = len(done)
    third = steps // 3
    thirds = [done[third - 1] if third else 0, done[2 * third - 1] if third else 0, done[-1]]
    rates = [thirds[0] / max(third, 1), (thirds[1] - thirds[0]) / max(third, 1),
             (thirds[2] - thirds[1]) / max(steps - 2 * third, 1)]  # fmt: skip
    per_step = done[-1] / steps
    best = None if spec.best is None else spec.best[0] / spec.best[1]
    # The first step, and the first after each resumption, load what later steps reuse
    # (every robot's first guide path; the compiled code, the threads).
    warm_ups = {0, *(resumed_at or [])}
    later_cpu = [t for k, t in enumerate(cpu) if k not in warm_ups] or cpu
    later_wall = [t for k, t in enumerate(wall) if k not in warm_ups] or wall
    return {
        "name": spec.name, "instance": name, "planner": spec.planner, "seed": spec.seed,
        "moves": spec.moves, "scheduler": spec.scheduler, "guidance": spec.guidance,
        "robots": robots, "steps": steps, "finished": done[-1], "per_step": per_step,
        "first_third": rates[0], "middle_third": rates[1], "last_third": rates[2],
        "last_over_middle": rates[2] / rates[1] if rates[1] else None,
        "best_known_per_step": best, "fraction_of_best": per_step / best if best else None,
        "refused": refused, "first_step_cpu_s": cpu[0], "first_step_wall_s": wall[0],
        "median_step_cpu_s": statistics.median(later_cpu), "max_step_cpu_s": max(later_cpu),
        "median_step_wall_s": statistics.median(later_wall), "max_step_wall_s": max(later_wall),
        "cpu_per_step_s": sum(cpu) / steps, "peak_mib": peak_mib,
        "resumed": len(resumed_at or []), "resumed_at": list(resumed_at or []),
    }  # fmt: skip


def write_row(folder: Path, row: dict[str, Any]) -> Path:
    """Write a finished run's row into ``folder``'s :data:`RUNS_DIR`, whole or not at all."""
    path = Path(folder) / RUNS_DIR / f"{row['name']}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(row, indent=1) + "\n")
    return path


def finished_rows(folder: Path, jobs: list[Job]) -> dict[str, dict[str, Any]]:
    """The rows of ``jobs`` that ``folder`` already holds (a file that does not read as
    its job's row is not finished), by job name."""
    rows = {}
    for job in jobs:
        path = Path(folder) / RUNS_DIR / f"{job.name}.json"
        try:
            row = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(row, dict) and row.get("name") == job.name and row.get("steps") == job.steps:
            rows[job.name] = row
    return rows
