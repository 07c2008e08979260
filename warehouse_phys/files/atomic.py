"""Writing files so that a failure never leaves a half-written one behind."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def current_umask() -> int:
    """The process's umask, read now (it can change while a program runs).

    Linux reports it in ``/proc/self/status``; elsewhere it can only be read
    by setting it and setting it back, which another thread could observe.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: How temporary files are named: ``.<name>.<random>.tmp`` beside ``<name>``.
TEMPORARY_PREFIX, TEMPORARY_SUFFIX = ".", ".tmp"


def temporary_files(folder: str | os.PathLike[str], name: str) -> list[Path]:
    """Temporary files that :func:`atomic_write` of ``folder/name`` left behind (a
    process killed while writing leaves one)."""
    prefix = f"{TEMPORARY_PREFIX}{name}."
    return sorted(
        entry
        for entry in Path(folder).iterdir()
        if entry.name.startswith(prefix) and entry.name.endswith(TEMPORARY_SUFFIX)
    )


def atomic_write(path: str | os.PathLike[str], write: Callable[[BinaryIO], None]) -> Path:
    """Write ``path`` through ``write(file)`` all at once, or not at all.

    ``write`` fills a temporary file in the same directory, which then replaces
    ``path`` in one ``os.replace``. If ``write`` raises, the temporary file is
    removed, ``path`` is left as it was (absent or the old version) and the
    error propagates. Returns ``path`` as a :class:`~pathlib.Path`. The file
    gets the permissions of a file opened with ``open(path, "w")``, not the
    owner-only ones of a temporary file.
    """
    path = Path(path)
    handle, temporary = tempfile.mkstemp(
        prefix=f"{TEMPORARY_PREFIX}{path.name}.", suffix=TEMPORARY_SUFFIX, dir=path.parent
    )
    try:
        os.fchmod(handle, 0o666 & ~current_umask())
        with os.fdopen(handle, "wb") as file:
            write(file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise
    return path


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; see :func:`atomic_write`."""
    return atomic_write(path, lambda file: file.write(text.encode("utf-8")))
