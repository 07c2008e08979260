"""A run's saved state, so that a run of hours killed half way goes on from where it was.

:func:`~warehouse_phys.apps.evaluate.suite.run_job` saves its whole state (the fleet, the
planner's policy, the last observations and what it has counted so far) every
``checkpoint_seconds`` of wall time into the suite's folder (:func:`checkpoint_path`),
whole or not at all; a run started again with the same job reads it back and plays on.
The two objects are pickled together, so the policy keeps its fleet, and a run resumed
at step ``k`` plays exactly the steps it would have played (the tests compare the two);
the times a step took come from both processes, and the row counts the resumptions.

A saved state is the package's own objects, so it is only read back by the same package:
a digest of the package's source, Python's version and NumPy's is saved with it, and a
checkpoint of another job or another version is not used (the run starts afresh). It is
a pickle, written by the command into its own suite's folder: read only your own.
"""

from __future__ import annotations

import hashlib
import pickle
import sys
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

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
    """A digest of the package's source files, Python's version and NumPy's."""
    digest = hashlib.sha256(f"{sys.version}|{np.__version__}".encode())
    root = Path(warehouse_phys.__file__).parent
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def checkpoint_path(folder: Path, runs_dir: str, name: str) -> Path:
    """Where the checkpoint of the job ``name`` lives in the suite's ``folder``."""
    return Path(folder) / runs_dir / f"{name}{CHECKPOINT_SUFFIX}"


def save_checkpoint(path: Path, job: dict[str, Any], state: RunState) -> None:
    """Save ``state``, the run of ``job`` (:meth:`Job.to_dict
    <warehouse_phys.apps.evaluate.suite.Job.to_dict>`), to ``path`` whole or not at all."""
    path.parent.mkdir(parents=True, exist_ok=True)
    saved = {"format": _FORMAT, "source": source_digest(), "job": job, "state": state}
    atomic_write(path, lambda file: pickle.dump(saved, file, protocol=pickle.HIGHEST_PROTOCOL))


def load_checkpoint(path: Path, job: dict[str, Any]) -> RunState | None:
    """The state saved at ``path`` for ``job``; None if there is none, or it is of another
    job or another version of the package, or it does not read."""
    try:
        with open(path, "rb") as file:
            saved = pickle.load(file)
    except Exception:  # none, or a file that does not read back: no checkpoint
        return None
    if (
        not isinstance(saved, dict)
        or saved.get("format") != _FORMAT
        or saved.get("source") != source_digest()
        or saved.get("job") != job
        or not isinstance(saved.get("state"), RunState)
    ):
        return None
    return saved["state"]
