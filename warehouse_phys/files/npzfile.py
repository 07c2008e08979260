"""Reading arrays from an ``.npz`` archive that may have been crafted to do harm.

``numpy.load`` trusts an archive's headers: a member may declare a shape of
10^14 elements, a header that is not Python literal syntax, a compression
method zipfile cannot read or an encrypted entry, and each gives its own
exception, or a ``MemoryError`` after a huge allocation; ``zipfile`` reads the
whole central directory, however many entries it lists. This reader checks the
archive's end record and every header against limits the caller gives *before*
reading or allocating anything, reads data a small chunk at a time straight into
the array that keeps it, and turns every problem into :class:`ArchiveError` with
one line that says what is wrong. It never unpickles (object arrays are refused).
"""

from __future__ import annotations

import io
import math
import struct
import zipfile
import zlib
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO

import numpy as np
import numpy.typing as npt

#: Longest NPY header read [bytes]; numpy's own limit for safe loading.
MAX_HEADER_BYTES = 10_000
#: Central directory allowed per expected member [bytes]: numpy writes about 60 (46 and the
#: name); the rest leaves room for the extra fields other zip tools add.
DIRECTORY_BYTES_PER_MEMBER = 1024
#: Data read at a time [bytes]: what reading holds besides the array it fills.
CHUNK_BYTES = 64 * 1024
#: Compression methods numpy writes; anything else is refused unread.
_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflated"}
_ENCRYPTED = 0x1  # bit 0 of a zip entry's general-purpose flags
_ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError)
# The zip format's end records (APPNOTE 4.3.14 to 4.3.16): signature, then the fields.
_END = struct.Struct("<4s4H2LH")  # ..., entries here, entries, directory size, offset, comment
_END_SIGNATURE = b"PK\x05\x06"
_LOCATOR = struct.Struct("<4sLQL")  # ..., disk, offset of the zip64 end record, disks
_LOCATOR_SIGNATURE = b"PK\x06\x07"
_END64 = struct.Struct("<4sQ2H2L4Q")  # ..., entries here, entries, directory size, offset
_END64_SIGNATURE = b"PK\x06\x06"


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

    ``members`` names the arrays the archive may hold (``"q"`` for ``q.npy``). Use as a
    context manager. Raises :class:`ArchiveError` for an archive that is not a zip
    file, is truncated or corrupt, lists more entries than ``members`` or holds another
    one (counted from its end record, before its directory is read), or whose entries
    use another compression method than numpy's or are encrypted.
    """

    def __init__(self, file: IO[bytes], *, members: Collection[str]) -> None:
        expected = sorted(f"{name}.npy" for name in members)
        wanted = " and ".join(map(repr, expected))
        try:
            # zipfile reads the whole directory into objects of about 600 bytes an entry:
            # its size is bounded first, from the end records.
            records = list(_end_records(file))
            entries = max((entries for entries, _ in records), default=0)
            directory_bytes = max((size for _, size in records), default=0)
            if entries > len(expected):
                raise ArchiveError(f"holds {entries:,} entries; expected only {wanted}")
            if directory_bytes > len(expected) * DIRECTORY_BYTES_PER_MEMBER:
                raise ArchiveError(
                    f"has a zip directory of {directory_bytes:,} bytes, more than {wanted} need"
                )
            file.seek(0)
            self._zip = zipfile.ZipFile(file)
        except ArchiveError:
            raise
        except _ZIP_ERRORS as error:
            raise ArchiveError(f"truncated or corrupt ({error})") from None
        self._entries = {info.filename: info for info in self._zip.infolist()}
        try:
            self._check_entries(expected, wanted)
        except ArchiveError:
            self._zip.close()
            raise

    def _check_entries(self, expected: list[str], wanted: str) -> None:
        for info in self._entries.values():
            if info.filename not in expected:
                raise ArchiveError(
                    f"holds an unexpected entry {info.filename!r}; expected only {wanted}"
                )
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

    def header(self, name: str, *, max_data_bytes: int) -> MemberHeader:
        """The header of array ``name``, read without its data.

        Raises:
            ArchiveError: if the member is missing, declares more than
                ``max_data_bytes`` of data, is not NPY data, holds objects (which
                need pickle), or its size in the archive is not its header's and data's.
        """
        with self._open(name, max_data_bytes) as (header, _):
            return header

    def read_ascii(self, name: str, *, max_data_bytes: int) -> bytearray:
        """The text of the 0-d string array ``name``, which must be ASCII, as bytes.

        Read :data:`CHUNK_BYTES` of the file at a time into a quarter of its data's size
        (numpy stores four bytes a character), its trailing NULs dropped as numpy drops
        them.

        Raises:
            ArchiveError: as :meth:`header` does, or if it is not a 0-d string array,
                holds a character other than ASCII, or is truncated or corrupt.
        """
        with self._open(name, max_data_bytes) as (header, member):
            if header.dtype.kind != "U" or header.shape != ():
                raise ArchiveError(f"array {name!r} is not a string")
            text = bytearray(header.data_bytes // 4)
            end = _read_ascii(member, text, header.dtype.byteorder, name)
            _check_end(member, name)
        del text[end:]
        return text

    def read_array(
        self, name: str, shape: tuple[int, ...], dtype: npt.DTypeLike = np.float64
    ) -> np.ndarray:
        """Array ``name``, which must have ``shape``, converted to ``dtype``.

        The result is allocated once and filled :data:`CHUNK_BYTES` of the file at a
        time: reading holds no second copy, whatever the stored dtype (it keeps the
        stored memory order). Converting follows numpy's casting: values too large for
        ``dtype`` become infinite.

        Raises:
            ArchiveError: as :meth:`header` does, or if its shape is not ``shape``, its
                dtype does not convert to ``dtype`` of the same kind, or it is truncated
                or corrupt.
        """
        dtype = np.dtype(dtype)
        widest = np.dtype(np.longdouble).itemsize
        with self._open(name, math.prod(shape) * widest) as (header, member):
            if header.shape != shape:
                raise ArchiveError(f"array {name!r} has shape {header.shape}, not {shape}")
            if not np.can_cast(header.dtype, dtype, casting="same_kind"):
                raise ArchiveError(f"array {name!r} holds {header.dtype}, not {dtype} values")
            out = np.empty(shape, dtype, order="F" if header.fortran_order else "C")
            _fill(member, out.ravel(order="K"), header.dtype, name)
            _check_end(member, name)
        return out

    @contextmanager
    def _open(self, name: str, max_data_bytes: int) -> Iterator[tuple[MemberHeader, IO[bytes]]]:
        """Member ``name`` open after its header, with the header checked against
        ``max_data_bytes`` and the member's size in the archive."""
        info = self._entries.get(f"{name}.npy")
        if info is None:
            raise ArchiveError(f"has no {name!r} array")
        if info.file_size > max_data_bytes + MAX_HEADER_BYTES + 16:
            raise ArchiveError(
                f"array {name!r} declares {info.file_size} bytes, more than the "
                f"{max_data_bytes} its data may hold"
            )
        try:
            stream = self._zip.open(info)
        except _ZIP_ERRORS as error:
            raise ArchiveError(f"truncated or corrupt ({error})") from None
        with stream:
            header, header_bytes = _parse_header(name, *_header_bytes(stream, name))
            if header.dtype.hasobject:
                raise ArchiveError(
                    f"array {name!r} is an object array, which needs pickle and is never loaded"
                )
            if header.data_bytes > max_data_bytes:
                raise ArchiveError(
                    f"array {name!r} declares shape {header.shape} of {header.dtype}, "
                    f"{header.data_bytes} bytes, more than the {max_data_bytes} it may hold"
                )
            stored = info.file_size - header_bytes
            if stored > header.data_bytes:
                raise ArchiveError(f"array {name!r} holds more than its header says")
            if stored < header.data_bytes:
                raise ArchiveError(
                    f"truncated or corrupt (array {name!r} holds {stored} bytes of data, "
                    f"its header declares {header.data_bytes})"
                )
            yield header, stream


def _end_records(file: IO[bytes]) -> Iterator[tuple[int, int]]:
    """``(entries, directory bytes)`` of every end record zipfile might read: the one
    that ends the file and the last one in its final 64 KiB (zipfile takes the first
    if it has no comment, else the second), and the zip64 record each points to
    (before it, and at the locator's offset). Reads at most 64 KiB."""
    file.seek(0, io.SEEK_END)
    size = file.tell()
    start = max(0, size - 2**16 - _END.size)
    file.seek(start)
    tail = file.read()
    found = {len(tail) - _END.size, tail.rfind(_END_SIGNATURE)}
    for at in sorted(at for at in found if at >= 0):
        record = tail[at : at + _END.size]
        if len(record) < _END.size or record[:4] != _END_SIGNATURE:
            continue
        fields = _END.unpack(record)
        yield max(fields[3], fields[4]), fields[5]
        locator = _read_at(file, start + at - _LOCATOR.size, _LOCATOR.size)
        if locator is None or locator[:4] != _LOCATOR_SIGNATURE:
            continue
        offset = _LOCATOR.unpack(locator)[2]
        for where in {start + at - _LOCATOR.size - _END64.size, offset}:
            record64 = _read_at(file, where, _END64.size)
            if record64 is not None and record64[:4] == _END64_SIGNATURE:
                fields64 = _END64.unpack(record64)
                yield max(fields64[6], fields64[7]), fields64[8]


def _read_at(file: IO[bytes], offset: int, size: int) -> bytes | None:
    """``size`` bytes at ``offset`` of ``file``, or None where the file has none."""
    if offset < 0:
        return None
    file.seek(offset)
    data = file.read(size)
    return data if len(data) == size else None


def _header_bytes(stream: IO[bytes], name: str) -> tuple[bytes, bytes, bytes]:
    """The magic string, the length field and the text of an NPY header. Reads at most
    :data:`MAX_HEADER_BYTES` of text: numpy would read the length a header declares, up
    to 4 GiB, before checking it."""
    try:
        magic = stream.read(np.lib.format.MAGIC_LEN)
        width = 2 if magic[-2:] == bytes((1, 0)) else 4  # versions 2 and 3: a 4-byte length
        length_bytes = stream.read(width)
        length = int.from_bytes(length_bytes, "little")
        if length > MAX_HEADER_BYTES:
            raise ArchiveError(
                f"array {name!r} is not NPY data (a header of {length} bytes, "
                f"more than {MAX_HEADER_BYTES})"
            )
        return magic, length_bytes, stream.read(length)
    except ArchiveError:
        raise
    except _ZIP_ERRORS as error:
        raise ArchiveError(f"truncated or corrupt ({error})") from None


def _parse_header(
    name: str, magic: bytes, length_bytes: bytes, text: bytes
) -> tuple[MemberHeader, int]:
    """The :class:`MemberHeader` an NPY header declares, whatever garbage it holds, and
    the header's length [bytes]."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(io.BytesIO(magic))
        if version == (1, 0):
            read = fmt.read_array_header_1_0
        elif version in ((2, 0), (3, 0)):
            read = fmt.read_array_header_2_0
        else:
            raise ValueError(f"NPY version {version} is not supported")
        stream = io.BytesIO(length_bytes + text)
        shape, fortran_order, dtype = read(stream, max_header_size=MAX_HEADER_BYTES)
    except Exception as error:  # numpy raises many kinds on a crafted header
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ArchiveError(f"array {name!r} is not NPY data ({reason})") from None
    if not all(isinstance(n, int) and n >= 0 for n in shape):
        raise ArchiveError(f"array {name!r} declares an invalid shape {shape!r}")
    header = MemberHeader(tuple(shape), bool(fortran_order), np.dtype(dtype))
    return header, len(magic) + len(length_bytes) + len(text)


def _fill(stream: IO[bytes], flat: np.ndarray, source: np.dtype, name: str) -> None:
    """Fill the contiguous 1-D ``flat`` with the ``source``-typed values ``stream`` holds
    next, converted: read straight into ``flat`` where the types agree, else through a
    buffer of :data:`CHUNK_BYTES`."""
    if source == flat.dtype:
        _read_exactly(stream, memoryview(flat).cast("B"), name)
        return
    step = max(1, CHUNK_BYTES // source.itemsize)
    buffer = bytearray(step * source.itemsize)
    for begin in range(0, flat.size, step):
        part = flat[begin : begin + step]
        view = memoryview(buffer)[: part.size * source.itemsize]
        _read_exactly(stream, view, name)
        np.copyto(part, np.frombuffer(view, dtype=source), casting="same_kind")


def _read_ascii(stream: IO[bytes], text: bytearray, byteorder: str, name: str) -> int:
    """Fill ``text`` with the ASCII characters of the four-byte codes ``stream`` holds
    next, :data:`CHUNK_BYTES` of them at a time; returns the length without trailing NULs."""
    codes = np.dtype(np.uint32).newbyteorder(byteorder)
    step = CHUNK_BYTES // codes.itemsize
    buffer = memoryview(bytearray(step * codes.itemsize))
    end = 0
    for begin in range(0, len(text), step):
        part = np.frombuffer(text, np.uint8, min(step, len(text) - begin), begin)
        view = buffer[: part.size * codes.itemsize]
        _read_exactly(stream, view, name)
        chunk = np.frombuffer(view, codes)
        if chunk.max(initial=0) > 127:
            raise ArchiveError(f"array {name!r} holds characters other than ASCII")
        part[:] = chunk
        if chunk.any():
            end = begin + int(np.flatnonzero(chunk)[-1]) + 1
    return end


def _read_exactly(stream: IO[bytes], view: memoryview, name: str) -> None:
    """Fill ``view`` from ``stream``, :data:`CHUNK_BYTES` at a time (zipfile's
    ``readinto`` reads into a temporary ``bytes`` of the requested size first)."""
    filled = 0
    try:
        while filled < len(view):
            got = stream.readinto(view[filled : filled + CHUNK_BYTES])
            if not got:
                raise ArchiveError(
                    f"truncated or corrupt (array {name!r} holds {filled} bytes of data, "
                    f"its header declares {len(view)})"
                )
            filled += got
    except ArchiveError:
        raise
    except _ZIP_ERRORS as error:
        raise ArchiveError(f"truncated or corrupt ({error})") from None


def _check_end(stream: IO[bytes], name: str) -> None:
    """Refuse a member with data after what its header declares (reading on to its end
    also checks its CRC)."""
    try:
        extra = stream.read(1)
    except _ZIP_ERRORS as error:
        raise ArchiveError(f"truncated or corrupt ({error})") from None
    if extra:
        raise ArchiveError(f"array {name!r} holds more than its header says")
