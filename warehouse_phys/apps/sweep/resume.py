"""Resuming a sweep in its folder: finished trials, the folder check, the locks.

Running the same command again with the same ``--out`` resumes: a trial whose folder
holds a complete run of its configuration (:func:`finished_row`) is not trained again. A
folder holding anything but a sweep's own files is refused (:func:`check_sweep_folder`).

A killed driver (SIGKILL) cannot shut Ray down: its workers, trials' included, live on
for seconds, Ray's agents for a minute. Running the sweep again in the same folder at
once is safe all the same:

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
"""

from __future__ import annotations

import fcntl
import json
import os
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from warehouse_phys.apps.cli import UsageError
from warehouse_phys.apps.runs import RUN_FILES, SUMMARY_FILE, TABLE_FILE
from warehouse_phys.apps.sweep.trials import (
    LOCK_FILE,
    RESULTS_CSV,
    RESULTS_JSON,
    SUMMARY_PNG,
    Trial,
    _measures,
    _row,
)
from warehouse_phys.files.atomic import TEMPORARY_PREFIX, TEMPORARY_SUFFIX
from warehouse_phys.files.runfolder import RunFolder, RunFolderError

#: What a sweep folder may hold: the sweep's tables, figure and lock, its run folders and Tune's.
SWEEP_ENTRIES = frozenset({RESULTS_CSV, RESULTS_JSON, SUMMARY_PNG, LOCK_FILE, "runs", "tune"})
#: How long a trial waits for its run folder while another process holds it (a
#: lingering worker of a killed sweep, which Ray ends within a minute or so) [s].
FOLDER_WAIT = 120.0


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
