"""A run folder: where one training run writes its files, and nobody else at the same time.

The policy, which ``python -m warehouse_phys.train`` follows:

- A new folder is created for the run. An existing one is used only if it is
  empty, or, with ``overwrite=True``, if it holds nothing but an earlier run's
  files, which are then removed before the run starts: a folder never mixes
  the files of two runs.
- While the run lasts, the process holds an exclusive lock on the folder
  (``flock``), so a second run into the same folder is refused at once; the
  operating system releases the lock when the process ends, however it ends.
- The folder is proven writable, by writing and removing a file, before any
  training starts. Temporary files that a killed run left behind are removed.
- Every file is written atomically (:mod:`warehouse_phys.files.atomic`), so each file
  in the folder is complete; a write that fails raises :class:`RunWriteError`
  naming the file and the reason, and the files written before it stay.
- A run that ends without writing a file (interrupted, failed) leaves no folder it
  created behind: neither its own nor the parents it made for it (``runs/`` on a
  first run), as long as they are empty (:func:`make_folders`, :func:`remove_empty`).
"""

from __future__ import annotations

import errno
import fcntl
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from types import TracebackType
from typing import TypeVar

from warehouse_phys.files.atomic import atomic_write, temporary_files

T = TypeVar("T")

#: The file with which a run folder is proven writable (removed at once).
_PROBE_FILE = "write-test"
#: Times :func:`make_folders` starts again when a parent it saw is removed meanwhile (by
#: another run's :func:`remove_empty`).
_MAKE_TRIES = 8


def make_folders(path: Path, *, exist_ok: bool) -> list[Path]:
    """Create the folder ``path`` and its missing parents; returns those this call
    created, innermost first (for :func:`remove_empty`).

    A parent that another process removes meanwhile (a run that created it and ended
    with it empty) is created again.

    Raises:
        FileExistsError: if ``path`` exists and not ``exist_ok``.
        OSError: if a folder cannot be created.
    """
    created: list[Path] = []
    for attempt in range(_MAKE_TRIES):
        missing = [folder for folder in path.parents if not folder.exists()]
        try:
            for folder in [*reversed(missing), path]:  # outermost first
                try:
                    folder.mkdir()
                except FileExistsError:
                    if folder == path and not exist_ok:
                        raise
                    continue  # made by another process just now: not ours to remove
                created.insert(0, folder)
            return created
        except FileNotFoundError:  # a parent was removed under us
            if attempt == _MAKE_TRIES - 1:
                remove_empty(created)
                raise
    return created


def remove_empty(folders: list[Path]) -> None:
    """Remove each of ``folders`` (innermost first, as :func:`make_folders` lists them)
    while it is empty; a folder that holds anything stops it (the folders around it hold
    it, then), and one already gone is passed over."""
    for folder in folders:
        try:
            folder.rmdir()
        except FileNotFoundError:
            continue
        except OSError:  # not empty (another run's folder in it), or not ours to remove
            return


class RunFolderError(Exception):
    """A run folder that this run may not use (not empty, in use, not a folder)."""


class RunWriteError(Exception):
    """A file of the run could not be written; the message names it and says why."""


def lock_folder(path: Path) -> int:
    """Lock the folder ``path`` for this process alone (an exclusive ``flock``, not
    waited for); returns the open folder's descriptor: closing it releases the lock, as
    the end of the process does, however it ends.

    Raises:
        RunFolderError: if another run holds the folder.
        RunWriteError: if the folder cannot be opened (missing, not a folder).
    """
    try:
        handle = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as error:
        raise _write_error(path, error) from None
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as error:
        os.close(handle)
        if error.errno in (errno.EWOULDBLOCK, errno.EAGAIN):
            raise RunFolderError(f"{path} is in use by another run") from None
        raise _write_error(path, error) from None
    return handle


class RunFolder:
    """The folder of one run, locked for it from :meth:`open` to :meth:`close`.

    Args:
        path: The folder.
        run_files: The names of the files a run writes there.
        overwrite: Whether a folder holding an earlier run's files (and
            nothing else) may be reused; those files are removed.
        new: Whether ``path`` must not exist yet: the folder is then created
            with ``os.mkdir``, which fails if another process created it first.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        run_files: Iterable[str],
        *,
        overwrite: bool = False,
        new: bool = False,
    ) -> None:
        self.path = Path(path)
        self.run_files = tuple(run_files)
        self.overwrite = overwrite
        self.new = new
        #: The names of the files written so far by :meth:`write`, in order.
        self.written: list[str] = []
        self._handle: int | None = None
        #: The folders :meth:`open` created, this one and its parents, innermost first.
        self._created: list[Path] = []

    def open(self) -> RunFolder:
        """Create or check the folder, lock it, clean it and prove it writable.

        Raises:
            RunFolderError: if the path is not a folder, the folder holds files
                of its own (or, without ``overwrite``, an earlier run's), or
                another run holds it.
            RunWriteError: if the folder cannot be created or written.
        """
        path = self.path
        try:
            exists = path.exists()
        except OSError as error:  # a name too long for the file system, say
            raise RunFolderError(f"{_short(path)}: {error.strerror or error}") from None
        if not exists and path.is_symlink():
            raise RunFolderError(f"{path} is a link to {os.readlink(path)}, which does not exist")
        if exists and not path.is_dir():
            raise RunFolderError(f"{path} exists and is not a folder")
        try:
            if self.new or not path.exists():
                self._created = make_folders(path, exist_ok=not self.new)
        except FileExistsError:
            raise RunFolderError(f"{path} was created by another run just now") from None
        except OSError as error:
            raise _write_error(path, error) from None
        self._handle = lock_folder(path)
        try:
            self._clean()
            self._prove_writable()
        except BaseException:
            self.close(remove_if_empty=True)
            raise
        return self

    def write(self, name: str, write: Callable[[Path], T]) -> T:
        """Call ``write(path)`` for the file ``name`` of the folder and record it as written.

        Raises:
            RunWriteError: naming the file, if writing it fails with an ``OSError``.
        """
        path = self.path / name
        try:
            result = write(path)
        except RunWriteError:
            raise
        except OSError as error:
            raise _write_error(path, error) from None
        self.written.append(name)
        return result

    def close(self, *, remove_if_empty: bool = False) -> None:
        """Release the lock. With ``remove_if_empty``, a folder this run created and
        wrote nothing into is removed too (an interrupted or failed run), and so are the
        parents it created for it while they are empty."""
        if remove_if_empty and self._created and not self.written:
            remove_empty(self._created)
            self._created = []
        self._release()

    def __enter__(self) -> RunFolder:
        return self.open()

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close(remove_if_empty=kind is not None)

    # ------------------------------------------------------------------ helpers
    def _release(self) -> None:
        if self._handle is not None:
            os.close(self._handle)  # releases the flock too
            self._handle = None

    def _clean(self) -> None:
        """Remove temporary files left behind; refuse a folder that is not this run's."""
        for name in (*self.run_files, _PROBE_FILE):
            for leftover in temporary_files(self.path, name):
                leftover.unlink(missing_ok=True)
        entries = sorted(entry.name for entry in self.path.iterdir())
        foreign = [name for name in entries if name not in self.run_files]
        if foreign:
            listed = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
            raise RunFolderError(
                f"{self.path} is not empty ({listed}); a run folder holds one run's files: "
                "choose a new folder"
            )
        if entries and not self.overwrite:
            raise RunFolderError(
                f"{self.path} holds an earlier run ({', '.join(entries)}); "
                "choose a new folder, or pass --overwrite to replace it"
            )
        for name in entries:  # an earlier run's files, which this run replaces
            try:
                (self.path / name).unlink()
            except OSError as error:
                raise _write_error(self.path / name, error) from None

    def _prove_writable(self) -> None:
        probe = self.path / _PROBE_FILE
        try:
            atomic_write(probe, lambda file: file.write(b"warehouse_phys\n"))
            probe.unlink()
        except OSError as error:
            raise _write_error(self.path, error) from None


def _short(path: Path) -> str:
    """``path`` for a one-line message: at most 80 characters."""
    text = str(path)
    return text if len(text) <= 80 else f"{text[:38]}...{text[-38:]} ({len(text)} characters)"


def _write_error(path: Path, error: OSError) -> RunWriteError:
    reason = error.strerror or str(error)
    return RunWriteError(f"cannot write {path}: {reason}")
