"""Writing files so that a failure never leaves a half-written one behind."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def _process_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: Read once: os.umask can only be read by setting it, which is not thread-safe.
_UMASK = _process_umask()


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
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(handle, 0o666 & ~_UMASK)
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
