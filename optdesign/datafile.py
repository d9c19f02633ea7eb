"""Data-only files: one JSON document and named numpy arrays in one zip.

The file is an ``.npz`` numpy can open (``np.load(path, allow_pickle=False)``)
with one more member, ``meta.json``.  It is read here without pickle and
without trusting a size the file declares: every member is stored (not
compressed), every array's header is checked (a plain numeric or boolean
dtype, a shape whose size matches the bytes present) before its bytes are
read, and the JSON is parsed with a size and nesting bound.  A file that is
anything else raises :class:`DataFileError`; nothing in it is executed.

The bytes written depend on the content only (fixed member times), so two
writes of the same state give the same file.
"""
from __future__ import annotations

import errno
import io
import json
import os
import re
import stat
import zipfile
from pathlib import Path

import numpy as np

__all__ = ["DataFileError", "dumps", "read", "MAX_BYTES"]

#: largest data file read (bytes)
MAX_BYTES = 256 * 2 ** 20
#: largest meta.json (bytes) and most members
MAX_META = 4 * 2 ** 20
MAX_MEMBERS = 4096
#: dtypes an array may have
DTYPES = {np.dtype(np.float64), np.dtype(np.int64), np.dtype(np.bool_)}
_NAME = re.compile(r"[A-Za-z0-9_.-]{1,128}")
_DATE = (1980, 1, 1, 0, 0, 0)


class DataFileError(ValueError):
    """The file is not a data file of this kind (the message says why)."""


def _info(name: str) -> zipfile.ZipInfo:
    zi = zipfile.ZipInfo(name, date_time=_DATE)
    zi.compress_type = zipfile.ZIP_STORED
    zi.external_attr = 0o644 << 16
    return zi


def dumps(meta: dict, arrays: dict[str, np.ndarray]) -> bytes:
    """The bytes of a data file holding ``meta`` (plain JSON: no NaN or
    infinity) and ``arrays`` (names of letters, digits, ``_.-``)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:
        zf.writestr(_info("meta.json"), json.dumps(meta, sort_keys=True, allow_nan=False).encode("utf-8"))
        for name, a in arrays.items():
            a = np.asarray(a)
            if not _NAME.fullmatch(name) or a.dtype not in DTYPES:
                raise ValueError(f"array {name!r} of dtype {a.dtype} cannot be stored")
            with zf.open(_info(f"{name}.npy"), "w") as fh:
                np.lib.format.write_array(fh, np.require(a, requirements="C"), version=(1, 0), allow_pickle=False)
    return buf.getvalue()


def _no_constant(text: str):
    raise DataFileError(f"meta.json: {text} is not a number JSON allows")


def _array(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    with zf.open(info) as fh:
        try:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh, max_header_size=2048)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh, max_header_size=2048)
            else:
                raise ValueError(f"npy format version {version}")
        except (ValueError, SyntaxError, TypeError) as exc:
            raise DataFileError(f"{info.filename}: not a plain .npy array ({exc})") from None
        if dtype not in DTYPES:
            raise DataFileError(f"{info.filename}: dtype {dtype} (expected float64, int64 or bool)")
        count = 1
        for n in shape:
            count *= int(n)
        nbytes = count * dtype.itemsize
        header = fh.tell()
        if header + nbytes != info.file_size:
            raise DataFileError(f"{info.filename}: {info.file_size - header} bytes of data for shape {shape}")
        data = fh.read(nbytes)
    a = np.frombuffer(data, dtype=dtype, count=count)
    return a.reshape(shape, order="F" if fortran else "C").copy()


def read(path: str | os.PathLike) -> tuple[dict, dict[str, np.ndarray]]:
    """``(meta, arrays)`` of a data file, or DataFileError."""
    path = Path(path)
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)     # never through a symbolic link (ELOOP)
    except FileNotFoundError:
        raise
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise DataFileError("a symbolic link (a run folder holds none)") from None
        raise DataFileError(f"cannot be read ({exc.strerror})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise DataFileError("not a regular file")
        if st.st_size > MAX_BYTES:
            raise DataFileError(f"larger than {MAX_BYTES // 2 ** 20} MiB")
    except BaseException:
        os.close(fd)
        raise
    with os.fdopen(fd, "rb") as fh:
        data = fh.read(MAX_BYTES + 1)
    if len(data) > MAX_BYTES:
        raise DataFileError(f"larger than {MAX_BYTES // 2 ** 20} MiB")
    try:
        zf = zipfile.ZipFile(io.BytesIO(data))
        infos = zf.infolist()
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as exc:
        raise DataFileError(f"not a data file ({exc})") from None
    names = [i.filename for i in infos]
    if len(infos) > MAX_MEMBERS or len(set(names)) != len(names) or "meta.json" not in names:
        raise DataFileError("not a data file (no meta.json, duplicate or too many members)")
    meta, arrays = None, {}
    try:
        for info in infos:
            if info.compress_type != zipfile.ZIP_STORED or info.flag_bits & 0x1:
                raise DataFileError(f"{info.filename}: compressed or encrypted member")
            if info.filename == "meta.json":
                if info.file_size > MAX_META:
                    raise DataFileError("meta.json: too large")
                try:
                    meta = json.loads(zf.read(info).decode("utf-8"), parse_constant=_no_constant)
                except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
                    raise DataFileError(f"meta.json: not valid JSON ({type(exc).__name__})") from None
                continue
            stem = info.filename[:-4] if info.filename.endswith(".npy") else ""
            if not _NAME.fullmatch(stem):
                raise DataFileError(f"unexpected member {info.filename[:80]!r}")
            arrays[stem] = _array(zf, info)
    except (zipfile.BadZipFile, EOFError, OSError) as exc:  # CRC mismatch, truncated member
        raise DataFileError(f"corrupted ({exc})") from None
    if not isinstance(meta, dict):
        raise DataFileError("meta.json: not a JSON object")
    return meta, arrays
