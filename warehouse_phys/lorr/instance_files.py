"""Reading a League of Robot Runners instance's files: any of them as bytes, bounded, with
one-line errors (:func:`read_bytes`), and the start and task files, a count then one line
of locations per start or task (:func:`read_locations`), read with array operations over
the file's bytes (never one Python object per task).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

#: Largest start or task file read [bytes]: 64 MiB, some 6 million locations.
MAX_LIST_BYTES = 64 << 20
#: A location's text: an optional sign and digits (at most 18, within int64).
_LOCATION = re.compile(rb"\s*[+-]?[0-9]{1,18}\s*")
_NEWLINE, _COMMA = ord("\n"), ord(",")


def shown(path: Path) -> str:
    """The name messages give ``path`` by: quoted if it holds a control character."""
    return str(path) if str(path).isprintable() else repr(str(path))


def read_bytes(path: Path, limit: int, what: str) -> bytes:
    """The bytes of ``path``, at most ``limit`` of them, or a one-line ``ValueError``
    naming the file and what file it should be (``what``: ``"instance"``, ``"start"``...)."""
    name = shown(path)
    try:
        if not path.is_file():
            raise ValueError(
                f"{name}: {'no such' if not path.exists() else 'not a regular file, no'} "
                f"{what} file"
            )
        with path.open("rb") as file:
            data = file.read(limit + 1)
    except OSError as error:
        raise ValueError(
            f"{name}: cannot read the {what} file: {error.strerror or error}"
        ) from None
    if len(data) > limit:
        raise ValueError(f"{name}: larger than any {what} file this reader takes ({limit:,} bytes)")
    return data


def read_locations(
    path: Path, what: str, *, limit: int | None, cells: int, single: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The lines of a start or task file after its count: ``(offsets, locations)`` as
    in :class:`~warehouse_phys.lorr.instances.LorrInstance` (line ``k``'s locations are
    ``locations[offsets[k]:offsets[k + 1]]``), at most ``limit`` lines (default: the
    count), each location checked to lie on the map (``0 <= location < cells``); with
    ``single``, each line one location (a start file's), else a ``ValueError``.

    The lines are found and their commas counted with array operations over the file's
    bytes; a Python loop runs only over comment lines and to name a faulty line."""
    name = shown(path)
    data = read_bytes(path, MAX_LIST_BYTES, what)
    count_line, count, body_start = _count_line(name, what, data)
    if limit is not None and count >= limit:
        count = limit  # the competition reads the team's starts, no more
    body, numbers = _body_lines(data, body_start, count_line, count)
    if len(numbers) < count:
        last = int(numbers[-1]) if len(numbers) else count_line
        raise ValueError(
            f"{name}, line {last + 1}: the count says {count:,} {what}s, the file has "
            f"{len(numbers):,}"
        )
    raw = np.frombuffer(body, dtype=np.uint8)
    ends = np.flatnonzero(raw == _NEWLINE)  # one per line: body ends with one
    commas = np.searchsorted(ends, np.flatnonzero(raw == _COMMA))
    sizes = np.bincount(commas, minlength=len(ends)) + 1
    if single and (sizes != 1).any():
        first = int(np.flatnonzero(sizes != 1)[0])
        text = body.split(b"\n")[first].strip()[:40].decode("ascii", "replace")
        raise ValueError(
            f"{name}, line {numbers[first]}: a {what} is one location (row * width + col), "
            f"got {text!r}"
        )
    offsets = np.zeros(len(ends) + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    try:
        values = np.array(body.replace(b",", b" ").split(), dtype=np.int64)
    except (ValueError, OverflowError):
        values = None
    if values is None or len(values) != offsets[-1]:
        _raise_bad_line(name, what, body.split(b"\n"), numbers)
    bad = (values < 0) | (values >= cells)
    if bad.any():
        line = numbers[int(np.searchsorted(offsets, np.flatnonzero(bad)[0], side="right")) - 1]
        raise ValueError(
            f"{name}, line {line}: location {int(values[bad][0])} is off the map "
            f"(0 to {cells - 1}); {int(bad.sum()):,} such locations in the file"
        )
    return offsets, values


def _count_line(name: str, what: str, data: bytes) -> tuple[int, int, int]:
    """The first line that is no comment, read as the count: its line number, the count,
    and where the next line begins in ``data``."""
    position, number = 0, 1
    while position < len(data):
        end = data.find(b"\n", position)
        end = len(data) if end < 0 else end
        text = data[position:end]
        if text.strip() and not text.lstrip().startswith(b"#"):
            if not _LOCATION.fullmatch(text) or int(text) < 0:
                raise ValueError(
                    f"{name}, line {number}: expected the number of {what}s, got "
                    f"{text[:40].decode('ascii', 'replace')!r}"
                )
            return number, int(text), end + 1
        position, number = end + 1, number + 1
    raise ValueError(f"{name}: no count of {what}s (the file is empty)")


def _body_lines(data: bytes, start: int, first_number: int, count: int) -> tuple[bytes, np.ndarray]:
    """The ``count`` lines from ``data[start:]`` on (fewer if the file ends first),
    leaving out comments (lines starting with ``#``, as the competition's reader does)
    and blank lines at the end; as bytes, each line ending in a newline, and their line
    numbers."""
    raw = np.frombuffer(data, dtype=np.uint8)[start:]
    ends = np.flatnonzero(raw == _NEWLINE)
    if len(raw) and (not len(ends) or ends[-1] != len(raw) - 1):
        ends = np.append(ends, len(raw))  # a last line without its newline
    if not len(ends):
        return b"", np.zeros(0, dtype=np.int64)
    begins = np.concatenate(([0], ends[:-1] + 1)).astype(np.int64)
    numbers = np.arange(first_number + 1, first_number + 1 + len(ends))
    comment = np.zeros(len(ends), dtype=bool)
    filled = begins < ends
    comment[filled] = raw[begins[filled]] == ord("#")
    if comment.any():
        begins, ends, numbers = begins[~comment], ends[~comment], numbers[~comment]
    n = len(begins)
    while n and not data[start + begins[n - 1] : start + ends[n - 1]].strip():
        n -= 1  # blank lines at the end are no lines
    n = min(n, count)
    begins, ends, numbers = begins[:n], ends[:n], numbers[:n]
    if not n:
        return b"", numbers
    if comment.any():
        pieces = zip(begins.tolist(), ends.tolist(), strict=True)
        return b"".join(data[start + b : start + e] + b"\n" for b, e in pieces), numbers
    return data[start : start + int(ends[-1])] + b"\n", numbers


def _raise_bad_line(name: str, what: str, lines: list[bytes], numbers: np.ndarray) -> None:
    """The ``ValueError`` of the first of ``lines`` that is no list of locations."""
    for number, text in zip(numbers.tolist(), lines, strict=False):
        parts = text.split(b",")
        for part in parts:
            if not _LOCATION.fullmatch(part):
                shown = part.strip()[:40].decode("ascii", "replace") or "nothing"
                raise ValueError(
                    f"{name}, line {number}: a {what} must be locations separated by commas "
                    f"(row * width + col), got {shown!r}"
                )
    raise ValueError(f"{name}: unreadable {what}s")  # pragma: no cover - found above
