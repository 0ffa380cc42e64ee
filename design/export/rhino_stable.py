"""Byte-stable ``.3dm`` files: the model's bytes without the run's time stamps, user name or file name.

OpenNURBS (through rhino3dm) writes a few things into every ``.3dm`` that
depend on when, where and by whom it was written rather than on the model:

- the **revision history** record of the properties table
  (``TCODE_PROPERTIES_REVISIONHISTORY``, ``ON_3dmRevisionHistory``): the
  creation and last-edit times (``ONX_Model::Write`` calls ``NewRevision()``,
  which stamps both with the current UTC second) and the creating / last
  editing user's name (empty on Linux, the login name on Windows, the full name on macOS),
  followed by the record's CRC-32;
- the **saved-as file name** record (``TCODE_PROPERTIES_AS_FILE_NAME``): the
  full path the archive was written to, a staging path in a temporary folder
  when the file is published atomically (Rhino only uses it to notice that a
  file has moved since it was saved). ``File3dm.Encode()``, which writes to
  memory, leaves it out; :func:`stable_3dm_bytes` writes that way, and
  :func:`normalize_3dm` drops the record if it is there;
- the **end-of-file** record (``TCODE_ENDOFFILE``) holds the file's length,
  which changes with the two records above.

Everything else (the start comment names the OpenNURBS build and operating
system, the tables hold the model) depends only on the model, the rhino3dm
build and the platform. :func:`normalize_3dm` rewrites the revision history
with both times set to ``SOURCE_DATE_EPOCH`` when that variable is set (the
reproducible-builds convention), otherwise 2000-01-01 00:00:00 UTC, and both
user names empty, recomputes the record's CRC-32, the properties table's
length and the end-of-file length, and copies every other byte unchanged.

Format (opennurbs_archive.cpp, opennurbs_3dm.h, version ≥ 5 archives): a
32-byte header, then chunks of a little-endian uint32 typecode and an int64
length (or value, for ``TCODE_SHORT`` typecodes) followed by that many bytes.
A chunk whose typecode has the ``TCODE_CRC`` bit ends with the zlib CRC-32 of
its own bytes (not of the chunks nested in it; the length counts the CRC).
"""

from __future__ import annotations

import os
import struct
import time
import zlib

from airmat.errors import AirmatError, InputError

__all__ = ["normalize_3dm", "stable_3dm_bytes", "fixed_time", "DEFAULT_EPOCH", "Malformed3dm"]

#: 2000-01-01 00:00:00 UTC: the time stamp when ``SOURCE_DATE_EPOCH`` is not set
DEFAULT_EPOCH = 946684800

_HEADER = 32
_TCODE_SHORT = 0x80000000
_TCODE_PROPERTIES_TABLE = 0x10000014
_TCODE_PROPERTIES_REVISIONHISTORY = 0x20008021
_TCODE_PROPERTIES_AS_FILE_NAME = 0x20008027
_TCODE_ENDOFFILE = 0x00007FFF
_CHUNK = struct.Struct("<Iq")           # typecode, length or value


class Malformed3dm(AirmatError, ValueError):
    """The bytes are not a version ≥ 5 .3dm archive laid out as OpenNURBS writes it (a rhino3dm that
    writes differently, or bytes that are not a .3dm)."""


def fixed_time(epoch: int | None = None) -> tuple:
    """The eight ints of a C ``struct tm`` (UTC) as OpenNURBS writes a time.

    Parameters
    ----------
    epoch : int, optional
        Seconds since 1970-01-01 UTC; default ``SOURCE_DATE_EPOCH`` if set, else :data:`DEFAULT_EPOCH`.

    Returns
    -------
    tuple of 8 int
        ``tm_sec, tm_min, tm_hour, tm_mday, tm_mon (0-11), tm_year (- 1900), tm_wday (Sunday 0), tm_yday (0-365)``.

    Raises
    ------
    airmat.errors.InputError
        ``SOURCE_DATE_EPOCH`` is set but not a whole number.

    Examples
    --------
    >>> fixed_time(946684800)
    (0, 0, 0, 1, 0, 100, 6, 0)
    """
    if epoch is None:
        env = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
        if env and not env.isdigit():
            raise InputError(f"SOURCE_DATE_EPOCH must be a whole number of seconds since 1970, got {env!r}")
        epoch = int(env) if env else DEFAULT_EPOCH
    t = time.gmtime(int(epoch))
    return (t.tm_sec, t.tm_min, t.tm_hour, t.tm_mday, t.tm_mon - 1, t.tm_year - 1900, (t.tm_wday + 1) % 7,
            t.tm_yday - 1)


def _chunks(data: bytes, start: int, end: int):
    """(typecode, whole chunk's bytes, its payload) of the chunks laid end to end in ``data[start:end]``."""
    pos = start
    while pos < end:
        if pos + _CHUNK.size > end:
            raise Malformed3dm(f"truncated chunk header at byte {pos}")
        typecode, value = _CHUNK.unpack_from(data, pos)
        size = 0 if typecode & _TCODE_SHORT else value
        if size < 0 or pos + _CHUNK.size + size > end:
            raise Malformed3dm(f"chunk {typecode:#010x} at byte {pos} runs past its container")
        yield typecode, data[pos:pos + _CHUNK.size + size], data[pos + _CHUNK.size:pos + _CHUNK.size + size]
        pos += _CHUNK.size + size


def _chunk(typecode: int, payload: bytes) -> bytes:
    return _CHUNK.pack(typecode, len(payload)) + payload


def _revision_count(payload: bytes) -> int:
    """The revision count of a revision-history payload (``ON_3dmRevisionHistory::Write``, chunk version 1.0)."""
    if len(payload) < 5 or zlib.crc32(payload[:-4]) != struct.unpack_from("<I", payload, len(payload) - 4)[0]:
        raise Malformed3dm("revision history whose CRC-32 does not match its bytes")
    try:
        if payload[0] >> 4 != 1:
            raise Malformed3dm(f"revision history version {payload[0] >> 4}.{payload[0] & 15}, expected 1.x")
        pos = 1
        for _ in range(2):                                  # (user name, time) twice
            (n,) = struct.unpack_from("<i", payload, pos)
            pos += 4 + 2 * n + 8 * 4                        # UTF-16 units with the terminator, 8 int32
        (count,) = struct.unpack_from("<i", payload, pos)
    except struct.error as exc:
        raise Malformed3dm("truncated revision history") from exc
    if pos + 4 + 4 != len(payload):
        raise Malformed3dm("revision history of unexpected length")
    return count


def _revision_history(count: int, when: tuple) -> bytes:
    body = bytes([0x10]) + struct.pack("<i8i", 0, *when) + struct.pack("<i8i", 0, *when) + struct.pack("<i", count)
    return body + struct.pack("<I", zlib.crc32(body))


def normalize_3dm(data: bytes, *, epoch: int | None = None) -> bytes:
    """The ``.3dm`` archive ``data`` with its revision history fixed and no saved-as file name.

    Parameters
    ----------
    data : bytes
        A version ≥ 5 archive as OpenNURBS writes it (``File3dm.Write`` or ``File3dm.Encode``).
    epoch : int, optional
        The creation and last-edit time (s since 1970 UTC); see :func:`fixed_time`.

    Returns
    -------
    bytes
        The same archive, with the fields listed in the module docstring normalized; every other
        chunk is copied byte for byte.

    Raises
    ------
    Malformed3dm
        ``data`` is not laid out as expected (no properties table, a version < 5 archive, a chunk
        running past the end).
    """
    if len(data) < _HEADER or not data.startswith(b"3D Geometry File Format "):
        raise Malformed3dm("not a .3dm archive")
    if int(data[24:_HEADER].decode("ascii", "replace").strip() or 0) < 5:
        raise Malformed3dm(f"archive version {data[24:_HEADER].strip()!r}: only version 5 and later are handled")
    when = fixed_time(epoch)
    out, seen = [data[:_HEADER]], False
    for typecode, whole, payload in _chunks(data, _HEADER, len(data)):
        if typecode == _TCODE_PROPERTIES_TABLE:
            records = []
            for sub, sub_whole, sub_payload in _chunks(payload, 0, len(payload)):
                if sub == _TCODE_PROPERTIES_AS_FILE_NAME:
                    continue
                if sub == _TCODE_PROPERTIES_REVISIONHISTORY:
                    sub_whole = _chunk(sub, _revision_history(_revision_count(sub_payload), when))
                records.append(sub_whole)
            whole, seen = _chunk(typecode, b"".join(records)), True
        elif typecode == _TCODE_ENDOFFILE:
            if len(payload) != 8:
                raise Malformed3dm("end-of-file chunk without a 64-bit file length")
            whole = _chunk(typecode, struct.pack("<Q", sum(map(len, out)) + len(whole)))
        out.append(whole)
    if not seen:
        raise Malformed3dm("no properties table")
    return b"".join(out)


def stable_3dm_bytes(model, version: int = 8, *, epoch: int | None = None) -> bytes:
    """A ``rhino3dm.File3dm`` as byte-stable ``.3dm`` bytes: written to memory, then :func:`normalize_3dm`.

    Parameters
    ----------
    model : rhino3dm.File3dm
    version : int
        The Rhino file version (8: Rhino 8).
    epoch : int, optional
        See :func:`fixed_time`.

    Returns
    -------
    bytes
        Empty when rhino3dm could not write the model. (Written to memory, the user table's header
        records the archive version as 80 where ``File3dm.Write(path, 8)`` records 8; both read back.)
    """
    import base64

    import rhino3dm

    options = rhino3dm.File3dmWriteOptions()
    options.Version = version
    data = base64.b64decode(model.Encode(options))
    return normalize_3dm(data, epoch=epoch) if data else b""
