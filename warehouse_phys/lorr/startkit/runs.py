"""Runs of the start kit (the entry's or its default entry's) and of ``simulate``, side by side.

:func:`run_kit` runs a built kit's ``lifelong`` on an instance, from a working folder of
its own that holds the entry's three files
(:func:`~warehouse_phys.lorr.startkit.install.install`), and reads what it reported:
its output file (``numTaskFinished``, ``numPlannerErrors``, ``numScheduleErrors``,
``numEntryTimeouts``, the ticks every robot waited for a late executor, written ``T``
in its planner paths) and its log, which holds what the output does not keep: every
motion the action model refused (``reason for waiting``: the output's ``errors`` hold
the last tick's only) and every check that found the planner late (``planner
timeout``). :func:`run_simulate` runs ``python -m warehouse_phys.simulate`` on the same
instance with the same delays (``--delays-from`` a kit run's output). Each run's wall
and CPU time are the child process's (``os.wait4``). :func:`comparison_table` sets the
runs side by side.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from warehouse_phys.lorr.output_2026 import TIMEOUT, read_output
from warehouse_phys.lorr.startkit.build import KitBuild
from warehouse_phys.lorr.startkit.install import install
from warehouse_phys.lorr.startkit.planner import ENTRY_PLANNERS

#: The three runs of ``python -m warehouse_phys.startkit run``.
RUNS = ("ours", "default", "simulate")
#: The kit's flags that load the entry's three Python components.
PYTHON_FLAGS = ("--plannerPython", "true", "--schedulerPython", "true", "--executorPython", "true")


@dataclass
class RunResult:
    """What one run did and reported."""

    #: ``"ours"`` (the kit with the entry), ``"default"`` (the kit's default entry),
    #: ``"simulate"`` (the package's own simulation of the entry by the kit's rules).
    name: str
    ticks: int
    tasks_finished: int | None = None
    #: Motions the kit's action model refused over the run (its log; ``simulate``: the
    #: squares its check found colliding).
    refused_motions: int | None = None
    #: The output's ``numPlannerErrors`` (the kit's: its last tick's errors only).
    planner_errors: int | None = None
    schedule_errors: int | None = None
    #: Checks that found the planner late (its log's ``planner timeout``).
    planner_late: int | None = None
    #: Rounds whose first command went on without the entry's scheduler's answer (the
    #: entry's log line; the kit may then count a finished task as a schedule error).
    scheduler_late: int | None = None
    #: Ticks every robot waited for a late entry: ``T`` in the planner paths (a late
    #: ``next_command``), and ticks the kit ran without recording them (a late first plan
    #: or ``process_new_plan``: its ``makespan`` less its paths' ticks); and the output's
    #: ``numEntryTimeouts``.
    timeout_ticks: int | None = None
    entry_timeouts: int | None = None
    wall_seconds: float = 0.0
    cpu_seconds: float = 0.0
    returncode: int = 0
    output: str | None = None
    log: str | None = None
    command: str = ""
    #: What differs from the kit's run (``simulate``), or why a run failed.
    note: str = ""
    #: The entry's calls' wall times (``ours``): per call, its count, median and
    #: slowest [ms] (:func:`call_timings`).
    timings: dict[str, dict[str, float]] | None = None

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def run_kit(
    build: KitBuild,
    instance: str | os.PathLike[str],
    out: str | os.PathLike[str],
    ticks: int,
    *,
    entry: str = "ours",
    agent_size: float = 1.0,
    extra: tuple[str, ...] = (),
    settings: dict[str, str] | None = None,
    timeout: float | None = None,
) -> RunResult:
    """Run the kit on ``instance`` for ``ticks`` ticks, writing ``out`` (its output file)
    and ``out`` with ``.log`` (its log); ``entry`` ``"ours"`` loads the entry's three
    components (the kit's flags ``extra`` may turn some back to the kit's own;
    ``settings``, the components' environment variables,
    :data:`~warehouse_phys.lorr.startkit.settings.SETTINGS`), ``"default"`` runs the
    kit's default entry."""
    out = Path(out).resolve()
    work = out.parent / f".{out.stem}-kit"
    work.mkdir(parents=True, exist_ok=True)
    install(work, force=True)
    command = [str(build.lifelong), "-i", str(Path(instance).resolve()), "-o", str(out),
               "-s", str(int(ticks))]  # fmt: skip
    if entry == "ours":
        flags = dict(zip(PYTHON_FLAGS[::2], PYTHON_FLAGS[1::2], strict=True))
        flags |= dict(zip(extra[::2], extra[1::2], strict=True))  # e.g. the kit's executor
        command += [part for flag in flags.items() for part in flag]
    timings = out.with_suffix(".timings")
    environment = {**os.environ, "WAREHOUSE_PHYS_AGENT_SIZE": repr(float(agent_size)),
                   "WAREHOUSE_PHYS_TIMINGS": str(timings), **(settings or {})}  # fmt: skip
    timings.unlink(missing_ok=True)
    log = out.with_suffix(".log")
    result = RunResult(entry, int(ticks), output=str(out), log=str(log),
                       command=shlex.join(command))  # fmt: skip
    if out.exists():
        out.unlink()
    code, wall, cpu = _timed(command, work, environment, log, timeout)
    result.returncode, result.wall_seconds, result.cpu_seconds = code, wall, cpu
    if code or not out.is_file():
        result.note = f"the kit exited with status {code} (log: {log})"
        return result
    _read_kit(result, out, log)
    if timings.is_file():
        result.timings = call_timings(timings)
    return result


def call_timings(path: Path) -> dict[str, dict[str, float]]:
    """The entry's calls' times from a ``WAREHOUSE_PHYS_TIMINGS`` file: per call, its
    ``count``, ``median_ms`` and ``max_ms`` (wall), ``cpu_median_ms`` (the CPU time of the
    calling thread, where the file has it: on a loaded machine the wall time is the
    machine's), and the share of calls over the kit's limit (``over_limit``, wall:
    ``plan`` and ``schedule`` together 1,000 ms a round, ``next_command`` and
    ``process_new_plan`` 100 ms each)."""
    seconds: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    for line in path.read_text().splitlines():
        call, *values = line.split()
        seconds.setdefault(call, []).append(float(values[0]))
        if len(values) > 1:
            cpu.setdefault(call, []).append(float(values[1]))
    limits = {"plan": 1.0, "schedule": 1.0, "next_command": 0.1, "process_new_plan": 0.1}
    for table in (seconds, cpu):
        rounds = [p + s for p, s in zip(table.get("plan", []), table.get("schedule", []),
                                        strict=False)]  # fmt: skip
        if rounds:
            table["round"] = rounds
    limits["round"] = 1.0
    timings = {}
    for call, values in seconds.items():
        timings[call] = {"count": len(values), "median_ms": 1000 * _median(values),
                         "max_ms": 1000 * max(values),
                         "over_limit": sum(v > limits.get(call, float("inf")) for v in values)
                         / len(values)}  # fmt: skip
        if cpu.get(call):
            timings[call]["cpu_median_ms"] = 1000 * _median(cpu[call])
    return timings


def _median(values: list[float]) -> float:
    return sorted(values)[len(values) // 2]


def run_simulate(
    instance: str | os.PathLike[str],
    folder: str | os.PathLike[str],
    ticks: int,
    *,
    delays_from: str | os.PathLike[str] | None,
    planner: str = ENTRY_PLANNERS[0],
    scheduler: str | None = None,
    guidance: Mapping[str, Any] | None = None,
    timeout: float | None = None,
) -> RunResult:
    """Run ``python -m warehouse_phys.simulate`` on ``instance`` for ``ticks`` ticks into
    the run folder ``folder``, replaying the delays of the kit run ``delays_from`` (its
    own draws when ``None``); ``scheduler`` ``None``: the entry's own; ``guidance``: the
    planner's fields (``--guidance``)."""
    folder = Path(folder).resolve()
    command = [sys.executable, "-m", "warehouse_phys.simulate", "--instance",
               str(Path(instance).resolve()), "--steps", str(int(ticks)), "--policy", planner,
               "--out", str(folder), "--overwrite", "--quiet", "--frames", "0",
               "--no-compare", *(("--scheduler", scheduler) if scheduler else ())]  # fmt: skip
    if delays_from is not None:
        command += ["--delays-from", str(Path(delays_from).resolve())]
    if guidance:
        command += ["--guidance", json.dumps(dict(guidance))]
    folder.parent.mkdir(parents=True, exist_ok=True)
    log = folder.parent / f"{folder.name}.log"
    result = RunResult("simulate", int(ticks), log=str(log), command=shlex.join(command))
    code, wall, cpu = _timed(command, Path.cwd(), dict(os.environ), log, timeout)
    result.returncode, result.wall_seconds, result.cpu_seconds = code, wall, cpu
    output = folder / "lorr-output.json"
    if code or not output.is_file():
        result.note = f"simulate exited with status {code} (log: {log})"
        return result
    data = json.loads(output.read_bytes())
    result.output = str(output)
    result.tasks_finished = int(data["numTaskFinished"])
    result.refused_motions = len(data.get("errors", []))
    result.planner_errors = int(data.get("numPlannerErrors", 0))
    result.schedule_errors = int(data.get("numScheduleErrors", 0))
    result.note = ("the same delays as the kit's run" if delays_from is not None
                   else "delays drawn by warehouse_phys (not the kit's stream)")  # fmt: skip
    return result


def comparison_table(results: list[RunResult]) -> str:
    """The runs side by side, one line each."""
    header = ("run", "tasks", "refused", "planner err", "schedule err", "planner late",
              "timeout ticks", "wall [s]", "CPU [s]")  # fmt: skip
    rows = [header]
    for r in results:
        rows.append(
            (
                r.name,
                _cell(r.tasks_finished),
                _cell(r.refused_motions),
                _cell(r.planner_errors),
                _cell(r.schedule_errors),
                _cell(r.planner_late),
                _cell(r.timeout_ticks),
                f"{r.wall_seconds:.1f}",
                f"{r.cpu_seconds:.1f}",
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(header))]
    lines = ["  ".join(cell.rjust(w) if i else cell.ljust(w) for i, (cell, w) in
                       enumerate(zip(row, widths, strict=True))) for row in rows]  # fmt: skip
    return "\n".join(lines)


def _cell(value: int | None) -> str:
    return "-" if value is None else f"{value:,}"


def _read_kit(result: RunResult, out: Path, log: Path) -> None:
    """Fill ``result`` from the kit's output file and its log."""
    read = read_output(out)
    data = read.data
    result.tasks_finished = int(data["numTaskFinished"])
    result.planner_errors = int(data.get("numPlannerErrors", 0))
    result.schedule_errors = int(data.get("numScheduleErrors", 0))
    result.entry_timeouts = int(data.get("numEntryTimeouts", 0))
    planned = read.planned
    waited = (
        0 if planned is None or not planned.size else int((planned == TIMEOUT).all(axis=0).sum())
    )
    # Ticks the kit ran without recording them: all robots waiting for a late first plan
    # or a late process_new_plan.
    unrecorded = int(data["makespan"]) - int(read.actual.shape[1])
    result.timeout_ticks = waited + unrecorded
    refused = late = unscheduled = 0
    with open(log, "rb") as text:
        for line in text:
            if b"reason for waiting" in line:
                refused += 1
            elif b"planner timeout" in line or b"planning) timeout" in line:
                late += 1
            elif b"without the scheduler's answer" in line:
                unscheduled += 1
    result.refused_motions, result.planner_late = refused, late
    result.scheduler_late = unscheduled


def _timed(
    command: list[str], cwd: Path, environment: dict[str, str], log: Path, timeout: float | None
) -> tuple[int, float, float]:
    """Run ``command`` with its output in ``log``; its exit status, wall and CPU seconds
    (the child's own, user and system)."""
    begun = time.perf_counter()
    with open(log, "wb") as out:
        child = subprocess.Popen(command, cwd=cwd, env=environment, stdout=out,
                                 stderr=subprocess.STDOUT)  # fmt: skip
        deadline = None if timeout is None else begun + timeout
        while True:
            pid, status, usage = os.wait4(child.pid, os.WNOHANG)
            if pid:
                break
            if deadline is not None and time.perf_counter() > deadline:
                child.kill()
                pid, status, usage = os.wait4(child.pid, 0)
                break
            time.sleep(0.05)
    child.returncode = os.waitstatus_to_exitcode(status)
    return child.returncode, time.perf_counter() - begun, usage.ru_utime + usage.ru_stime
