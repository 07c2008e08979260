"""Reading arrays from an ``.npz`` archive that may have been crafted to do harm.

``numpy.load`` trusts an archive's headers: a member may declare a shape of
10^14 elements, a header that is not Python literal syntax, a compression
method zipfile cannot read or an encrypted entry, and each gives its own
exception, or a ``MemoryError`` after a huge allocation. This reader checks
every header against limits the caller gives *before* reading or allocating
anything, and turns every problem into :class:`ArchiveError` with one line
that says what is wrong. It never unpickles (object arrays are refused).
"""

from __future__ import annotations

import io
import math
import zipfile
import zlib
from dataclasses import dataclass

import numpy as np

#: Longest NPY header read [bytes]; numpy's own limit for safe loading.
MAX_HEADER_BYTES = 10_000
#: Compression methods numpy writes; anything else is refused unread.
_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflated"}
_ENCRYPTED = 0x1  # bit 0 of a zip entry's general-purpose flags


class ArchiveError(ValueError):
    """An archive or one of its members cannot be used; the message says why."""


@dataclass(frozen=True)
class MemberHeader:
    """What a member's NPY header declares."""

    shape: tuple[int, ...]
    fortran_order: bool
    dtype: np.dtype

    @property
    def data_bytes(self) -> int:
        return math.prod(self.shape) * self.dtype.itemsize


class NpzReader:
    """The members of an ``.npz`` archive, read one at a time within limits.

    Use as a context manager. Raises :class:`ArchiveError` for an archive that
    is not a zip file, is truncated or corrupt, or whose entries use another
    compression method than numpy's or are encrypted.
    """

    def __init__(self, file: io.BufferedIOBase) -> None:
        try:
            self._zip = zipfile.ZipFile(file)
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError) as error:
            raise ArchiveError(f"truncated or corrupt ({error})") from None
        self._entries = {info.filename: info for info in self._zip.infolist()}
        for info in self._entries.values():
            if info.flag_bits & _ENCRYPTED:
                raise ArchiveError(f"member {info.filename!r} is encrypted")
            if info.compress_type not in _METHODS:
                raise ArchiveError(
                    f"member {info.filename!r} uses zip compression method "
                    f"{info.compress_type}; numpy's archives are stored or deflated"
                )

    def __enter__(self) -> NpzReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self._zip.close()

    @property
    def names(self) -> list[str]:
        """The array names, as ``numpy.load`` gives them (``"q"`` for ``q.npy``)."""
        return [name.removesuffix(".npy") for name in self._entries]

    def read(self, name: str, *, max_data_bytes: int) -> tuple[MemberHeader, bytes]:
        """The header and the raw data of array ``name``.

        Raises:
            ArchiveError: if the member is missing, declares more than
                ``max_data_bytes`` of data (checked before reading it), is not
                NPY data, holds objects (which need pickle), or is truncated.
        """
        info = self._entries.get(f"{name}.npy")
        if info is None:
            raise ArchiveError(f"has no {name!r} array")
        limit = max_data_bytes + MAX_HEADER_BYTES + 16
        if info.file_size > limit:
            raise ArchiveError(
                f"array {name!r} declares {info.file_size} bytes, more than the "
                f"{max_data_bytes} its data may hold"
            )
        try:
            with self._zip.open(info) as member:
                raw = member.read(limit + 1)
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError) as error:
            raise ArchiveError(f"truncated or corrupt ({error})") from None
        if len(raw) > limit:
            raise ArchiveError(f"array {name!r} holds more than its header says")
        stream = io.BytesIO(raw)
        header = _read_header(name, stream)
        if header.dtype.hasobject:
            raise ArchiveError(
                f"array {name!r} is an object array, which needs pickle and is never loaded"
            )
        if header.data_bytes > max_data_bytes:
            raise ArchiveError(
                f"array {name!r} declares shape {header.shape} of {header.dtype}, "
                f"{header.data_bytes} bytes, more than the {max_data_bytes} it may hold"
            )
        data = stream.read()
        if len(data) != header.data_bytes:
            raise ArchiveError(
                f"truncated or corrupt (array {name!r} holds {len(data)} bytes of data, "
                f"its header declares {header.data_bytes})"
            )
        return header, data


def _read_header(name: str, stream: io.BytesIO) -> MemberHeader:
    """Parse an NPY header, whatever garbage it holds, into a :class:`MemberHeader`."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(stream)
        if version == (1, 0):
            shape, fortran_order, dtype = fmt.read_array_header_1_0(
                stream, max_header_size=MAX_HEADER_BYTES
            )
        elif version in ((2, 0), (3, 0)):
            shape, fortran_order, dtype = fmt.read_array_header_2_0(
                stream, max_header_size=MAX_HEADER_BYTES
            )
        else:
            raise ValueError(f"NPY version {version} is not supported")
    except Exception as error:  # numpy raises many kinds on a crafted header
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ArchiveError(f"array {name!r} is not NPY data ({reason})") from None
    if not all(isinstance(n, int) and n >= 0 for n in shape):
        raise ArchiveError(f"array {name!r} declares an invalid shape {shape!r}")
    return MemberHeader(tuple(shape), bool(fortran_order), np.dtype(dtype))


def to_array(header: MemberHeader, data: bytes) -> np.ndarray:
    """The array that ``header`` and ``data`` (from :meth:`NpzReader.read`) describe."""
    flat = np.frombuffer(data, dtype=header.dtype, count=math.prod(header.shape))
    return flat.reshape(header.shape, order="F" if header.fortran_order else "C")
