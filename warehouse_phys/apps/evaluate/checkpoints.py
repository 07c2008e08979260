"""A run's saved state, so that a run of hours killed half way goes on from where it was.

:func:`~warehouse_phys.apps.evaluate.suite.run_job` saves its whole state (the fleet, the
planner's policy, the last observations and what it has counted so far) every
``checkpoint_seconds`` of wall time into the suite's folder (:func:`checkpoint_path`),
whole or not at all; a run started again with the same job reads it back and plays on.
The two objects are pickled together, so the policy keeps its fleet, and a run resumed
at step ``k`` plays exactly the steps it would have played, as long as no time limit
bounds the planner (``time_limit``, ``first_time_limit``, ``repair_time_limit``: those
runs differ from run to run anyway). The times a step took then come from more than one
process; the row counts the resumptions (one killed again before it saved counts once).

A saved state is the package's own objects, so it is only read back by the same code on
the same instance: a header saved first holds a digest of the package's files, Python's,
NumPy's and Numba's versions and the instance file's bytes, and a checkpoint whose
header does not match (another job, version or instance) is not read further: the run
starts afresh. A checkpoint is a pickle that the command writes into its own suite's
folder: read only your own. One holds a fleet's distance maps (up to some 2 GiB at
10,000 robots), twice that while the next one is written beside it.
"""

from __future__ import annotations

import hashlib
import pickle
import sys
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

import warehouse_phys
from warehouse_phys.files.atomic import atomic_write

#: The ending of a run's checkpoint, beside its row in the suite's runs folder.
CHECKPOINT_SUFFIX = ".checkpoint.pickle"
#: Wall time between two checkpoints of a run [s]: a few seconds to write a 10,000-robot
#: fleet's state (its distance maps, up to some 2 GiB), every ten minutes.
CHECKPOINT_SECONDS = 600.0
#: The layout of what a checkpoint holds; one of another layout is not read.
_FORMAT = 1


@dataclass
class Progress:
    """What a run has counted so far: each step's CPU and wall time [s], what was
    finished by each step's end, the moves refused, the steps it was resumed at, and
    the peak memory of the processes it ran in before [MiB]."""

    cpu: list[float] = field(default_factory=list)
    wall: list[float] = field(default_factory=list)
    done: list[int] = field(default_factory=list)
    refused: int = 0
    resumed_at: list[int] = field(default_factory=list)
    peak_mib: float = 0.0


@dataclass
class RunState:
    """A run between two steps: its fleet, its policy, the fleet's last observations and
    infos, and its :class:`Progress`."""

    env: Any
    policy: Any
    observations: dict[str, Any]
    infos: dict[str, Any]
    progress: Progress


@cache
def source_digest() -> str:
    """A digest of the package's files (its compiled caches left out) and of Python's,
    NumPy's and Numba's versions."""
    from importlib.metadata import version

    digest = hashlib.sha256(f"{sys.version}|{np.__version__}|{version('numba')}".encode())
    root = Path(warehouse_phys.__file__).parent
    for path in sorted(root.rglob("*")):
        if path.is_file() and "__pycache__" not in path.parts:
            digest.update(f"{path.relative_to(root)}".encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def checkpoint_path(folder: Path, runs_dir: str, name: str) -> Path:
    """Where the checkpoint of the job ``name`` lives in the suite's ``folder``."""
    return Path(folder) / runs_dir / f"{name}{CHECKPOINT_SUFFIX}"


def _header(job: dict[str, Any]) -> dict[str, Any]:
    """What a checkpoint of ``job`` must say before its state is read."""
    instance = hashlib.sha256(Path(job["instance"]).read_bytes()).hexdigest()
    return {"format": _FORMAT, "source": source_digest(), "instance": instance, "job": job}


def save_checkpoint(path: Path, job: dict[str, Any], state: RunState) -> None:
    """Save ``state``, the run of ``job`` (:meth:`Job.to_dict
    <warehouse_phys.apps.evaluate.suite.Job.to_dict>`), to ``path`` whole or not at all:
    its header, then the state.

    Raises:
        OSError: if the file cannot be written (the previous checkpoint is kept).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    header = _header(job)

    def write(file: BinaryIO) -> None:
        pickle.dump(header, file, protocol=pickle.HIGHEST_PROTOCOL)
        pickle.dump(state, file, protocol=pickle.HIGHEST_PROTOCOL)

    atomic_write(path, write)


def load_checkpoint(path: Path, job: dict[str, Any]) -> RunState | None:
    """The state saved at ``path`` for ``job``; None if there is none, or its header is of
    another job, version or instance (the state is then not read), or it does not read."""
    try:
        with open(path, "rb") as file:
            if pickle.load(file) != _header(job):
                return None
            state = pickle.load(file)
    except Exception:  # none, or a file that does not read back: no checkpoint
        return None
    return state if isinstance(state, RunState) else None
