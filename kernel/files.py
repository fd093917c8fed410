"""Files every stage writes and reads: UTF-8 text, TOML, JSON documents, Parquet and
CSV tables in (each checked, errors naming the file), JSON, Parquet and CSV out by
atomic replacement, and content hashes.

A stage never leaves a half-written output: it writes a temporary sibling of
the target (same directory, so the same file system) and moves it into place
with :func:`os.replace` only once the write succeeded.
"""

from __future__ import annotations

import codecs
import contextlib
import errno
import hashlib
import json
import math
import os
import re
import tempfile
import tomllib
from collections.abc import Callable, Iterator
from datetime import date, time
from pathlib import Path
from typing import Any

from kernel.errors import InputError
from kernel.output_place import check_place

#: OS errors that mean "this place cannot be written", said plainly by the CLI
WRITE_ERRNOS = {errno.EACCES: "permission denied", errno.EPERM: "operation not permitted",
                errno.EROFS: "read-only file system", errno.ENOSPC: "no space left on device",
                errno.EDQUOT: "disk quota exceeded"}


def temp_path(path: str | Path) -> Path:
    """Create an empty, uniquely named temporary sibling of ``path`` and return it.

    The parent directory is created if needed.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    return Path(tmp)


def commit(tmp: str | Path, path: str | Path) -> Path:
    """Move a complete temporary file onto ``path``, with a new file's usual permissions.

    ``mkstemp`` creates files readable by their owner only (0600); outputs are
    meant to be shared, so they get 0666 minus the process umask.
    """
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)
    return Path(path)


def discard(tmp: str | Path) -> None:
    """Remove a temporary file that will not be committed (no error if it is gone)."""
    Path(tmp).unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path; on success it replaces ``path``, on error it is removed."""
    tmp = temp_path(path)
    try:
        yield tmp
    except BaseException:
        discard(tmp)
        raise
    commit(tmp, path)


def atomic_write(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on a temporary sibling of ``path``, then move it into place."""
    with atomic_path(path) as tmp:
        write(tmp)
    return Path(path)


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically, line ends as given on every platform."""
    return atomic_write(path, lambda tmp: tmp.write_bytes(text.encode("utf-8")))


def require_regular(path: Path) -> None:
    """Raise InputError when ``path`` exists but is no regular file (FIFO, device, folder).

    Opening a FIFO waits for a writer forever; a device may never end.
    """
    if path.exists() and not path.is_file():
        raise InputError(path, "not a regular file (a FIFO, device or folder)",
                         expected="a text file")


def read_text(path: str | Path, *, what: str = "file") -> str:
    """The text of a UTF-8 file (a leading byte-order mark is dropped).

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for the error message (``"system file"``, ``"mapping file"``).

    Raises
    ------
    InputError
        The file cannot be read, or is not UTF-8 text: the message names the
        file, the line of the first undecodable byte and, when it can tell, the
        encoding the file seems to be in (UTF-16, Latin-1).
    """
    path = Path(path)
    require_regular(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot read the {what} ({exc.strerror or exc})",
                         expected=f"a readable {what}") from None
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        raise InputError(path, f"the {what} is UTF-16 text (it starts with a UTF-16 "
                         "byte-order mark)", line=1, expected=_UTF8_EXPECTED)
    if b"\x00" in data:
        line = data[: data.index(b"\x00")].count(b"\n") + 1
        raise InputError(path, f"the {what} contains NUL bytes (UTF-16 text or binary data?)",
                         line=line, expected=_UTF8_EXPECTED)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        byte = data[exc.start]
        guess = " (Latin-1 or Windows-1252 text?)" if byte >= 0x80 else ""
        raise InputError(path, f"byte 0x{byte:02x} of the {what} is not UTF-8{guess}",
                         line=line, expected=_UTF8_EXPECTED) from None


_UTF8_EXPECTED = "UTF-8 text (save the file as UTF-8)"


def parse_toml(text: str, path: str | Path | None, *, what: str = "file") -> dict:
    """The table of TOML ``text`` read from ``path`` (named in the error).

    Raises
    ------
    InputError
        ``text`` is not valid TOML (with the line of the error).
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        found = re.search(r"at line (\d+)", str(exc))
        raise InputError(path, f"the {what} is not valid TOML ({exc})",
                         line=int(found.group(1)) if found else None,
                         expected="TOML (https://toml.io)") from None


def read_toml(path: str | Path, *, what: str = "file") -> dict:
    """The table of a UTF-8 TOML file.

    Raises
    ------
    InputError
        The file cannot be read, is not UTF-8 (see :func:`read_text`), or is
        not valid TOML; the file, and the line when known, are named.
    """
    return parse_toml(read_text(path, what=what), path, what=what)


def parse_json(text: str, path: str | Path | None, *, what: str = "file") -> Any:
    """The value of JSON ``text`` read from ``path`` (named in the error).

    Raises
    ------
    InputError
        ``text`` is not valid JSON (with the line of the error), or holds a number
        Python does not convert (an integer of thousands of digits).
    """
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON: {exc.msg}", line=exc.lineno,
                         expected=f"the {what} as JSON (https://www.json.org)") from None
    except ValueError as exc:
        raise InputError(path, f"not valid JSON: {exc}",
                         expected=f"the {what} as JSON (https://www.json.org)") from None


def read_json(path: str | Path, *, what: str = "file") -> Any:
    """The value of a UTF-8 JSON file.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for the error message (``"store manifest"``, ``"power model file"``).

    Raises
    ------
    InputError
        The file cannot be read, is not UTF-8 (see :func:`read_text`), or is not
        valid JSON; the file, and the line when known, are named.
    """
    return parse_json(read_text(path, what=what), path, what=what)


# ------------------------------------------------------------------ JSON and Parquet
def json_safe(value: Any) -> Any:
    """Copy of nested dicts/lists/tuples with numpy scalars and arrays as Python
    values, dates and times as ISO 8601 text, and NaN/inf as ``None``."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # numpy scalar or array
        return json_safe(value.tolist())
    if isinstance(value, date | time):
        return value.isoformat()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist") and hasattr(value, "dtype"):
        return value.tolist()
    if isinstance(value, date | time):
        return value.isoformat()
    raise TypeError(f"cannot write a {type(value).__name__} as JSON: {value!r}")


def dumps_json(data: Any, *, indent: int = 2, sort_keys: bool = False,
               non_finite: str = "null") -> str:
    """JSON text of ``data``, ending in a newline.

    Parameters
    ----------
    data : Any
        Nested dicts, lists and numbers; numpy values and dates are converted.
    indent : int
    sort_keys : bool
        Sorted keys give stable bytes (content hashes of manifests).
    non_finite : {"null", "error", "nan"}
        NaN and inf become ``null``, raise :class:`ValueError` (JSON has neither),
        or are written as ``NaN``/``Infinity`` (Python's extension, for caches
        read back only by this package).
    """
    if non_finite == "null":
        data = json_safe(data)
    elif non_finite not in ("error", "nan"):
        raise ValueError(f"non_finite must be 'null', 'error' or 'nan', not {non_finite!r}")
    return json.dumps(data, indent=indent, sort_keys=sort_keys,
                      allow_nan=non_finite == "nan", default=_json_default) + "\n"


def write_json(path: str | Path, data: Any, **options: Any) -> Path:
    """Write ``data`` as JSON to ``path`` atomically (``options``: see :func:`dumps_json`)."""
    return write_text_atomic(path, dumps_json(data, **options))


def write_parquet(path: str | Path, frame: Any, *, descriptions: dict[str, str] | None = None,
                  metadata: dict[str, Any] | None = None) -> Path:
    """Write a DataFrame to Parquet atomically, each field carrying its unit.

    Every field's metadata gets ``{"unit": ...}`` (from the column name, see
    :func:`kernel.units.unit_of`; no key when the name has no unit) and, when
    given, ``{"description": ...}``.

    Parameters
    ----------
    path : str or Path
    frame : pandas.DataFrame
    descriptions : dict, optional
        Column -> meaning, written into the field metadata.
    metadata : dict, optional
        File-level key/value metadata: ``str`` values are written as they are,
        anything else JSON-encoded.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from kernel.units import unit_of

    table = pa.Table.from_pandas(frame, preserve_index=False)
    fields = []
    for f in table.schema:
        meta = {"unit": unit_of(f.name)} if unit_of(f.name) else {}
        if descriptions and f.name in descriptions:
            meta["description"] = descriptions[f.name]
        fields.append(f.with_metadata(meta) if meta else f)
    file_meta = dict(table.schema.metadata or {})
    for key, value in (metadata or {}).items():
        text = value if isinstance(value, str) else json.dumps(value, default=_json_default)
        file_meta[key.encode()] = text.encode("utf-8")
    table = pa.Table.from_arrays(table.columns, schema=pa.schema(fields, metadata=file_meta))
    return atomic_write(path, lambda tmp: pq.write_table(table, tmp))


def write_csv(path: str | Path, frame: Any) -> Path:
    """Write a DataFrame as CSV (no index) atomically."""
    return atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False))


def check_columns(columns, required: tuple[str, ...], path: str | Path) -> None:
    """Raise InputError naming the first of ``required`` absent from ``columns``."""
    absent = [c for c in required if c not in columns]
    if absent:
        raise InputError(path, f"columns {absent} missing", column=absent[0],
                         expected=", ".join(required))


def _require_file(path: Path, expected: str) -> None:
    if not path.is_file():
        raise InputError(path, "file not found", expected=expected)


def read_parquet(path: str | Path, required: tuple[str, ...] = (),
                 columns: tuple[str, ...] | None = None, *, expected: str = "a Parquet file"):
    """A Parquet file as a DataFrame, its ``required`` columns checked first.

    Parameters
    ----------
    path : str or Path
    required : tuple of str
        Columns the file must have.
    columns : tuple of str, optional
        Read only these (default all).
    expected : str
        What the file should be, for the error message (``"the output of bench fit"``).

    Raises
    ------
    InputError
        The file is missing, not readable Parquet, or lacks a required column.
    """
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    _require_file(path, expected)
    try:
        check_columns(pq.read_schema(path).names, required, path)
        return pd.read_parquet(path, columns=list(columns) if columns else None)
    except (OSError, pa.ArrowException) as exc:
        raise InputError(path, f"not a readable Parquet file ({exc})", expected=expected) from exc


def read_csv(path: str | Path, required: tuple[str, ...] = (), *,
             expected: str = "a CSV file"):
    """A CSV file written by :func:`write_csv` (English locale, empty cells as text),
    its ``required`` columns checked.

    Raises
    ------
    InputError
        The file is missing, not readable CSV, or lacks a required column.
    """
    import pandas as pd

    path = Path(path)
    _require_file(path, expected)
    try:
        frame = pd.read_csv(path, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not a readable CSV file: {exc}", expected=expected) from exc
    check_columns(frame.columns, required, path)
    return frame


def read_document(path: str | Path, schema: str, *, expected: str) -> dict:
    """A stage's JSON document whose ``"schema"`` is ``schema``.

    Raises
    ------
    InputError
        The file is missing, not JSON, or not a JSON object of that schema.
    """
    path = Path(path)
    _require_file(path, expected)
    doc = read_json(path, what=expected)
    if not isinstance(doc, dict) or doc.get("schema") != schema:
        raise InputError(path, f"not a {schema} document", expected=f'"schema": "{schema}"')
    return doc


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def recorded_mismatch(path: str | Path, record: dict, data: bytes | None = None) -> str | None:
    """How a file differs from its record ``{"bytes": n, "sha256": hex}``; None when it matches.

    The one check of a file against the size and SHA-256 a store manifest or an
    output folder's ``run.json`` recorded for it.

    Parameters
    ----------
    path : str or Path
        The file.
    record : dict
        Its recorded size [bytes] and SHA-256 (hex).
    data : bytes, optional
        The file's bytes when the caller has read them already (they are checked,
        not the file again, so what is parsed is what was checked).

    Returns
    -------
    str or None
        ``"missing"``, ``"<n> bytes, <m> recorded"`` or ``"content differs from the
        recorded SHA-256 ..."``.
    """
    path = Path(path)
    if data is None and not path.is_file():
        return "missing"
    size = len(data) if data is not None else path.stat().st_size
    if size != record.get("bytes"):
        return f"{size} bytes, {record.get('bytes')} recorded"
    digest = hashlib.sha256(data).hexdigest() if data is not None else file_sha256(path)
    if digest != record.get("sha256"):
        return "content differs from the recorded SHA-256 (bit rot, an edit or another run's file)"
    return None


def raise_mismatches(problems: list[tuple[Path, str]], record: str, repair: str) -> None:
    """Raise one InputError naming every file that differs from its record (none: return).

    Parameters
    ----------
    problems : list of (Path, str)
        Each file with :func:`recorded_mismatch`'s description of it.
    record : str
        Where the record is, for the message (``"the store manifest"``, ``"run.json"``).
    repair : str
        The command that repairs the input, for the message.
    """
    if not problems:
        return
    first, what = problems[0]
    more = "".join(f"; {p}: {w}" for p, w in problems[1:])
    raise InputError(first, f"{what} (against {record}){more}",
                     expected=f"the files as recorded: {repair}")


def check_output_dir(path: str | Path, option: str = "--out") -> Path:
    """Fail early, before any long work, if ``path`` cannot become an output folder.

    The folder (or, when missing, its nearest existing parent) must be a folder
    in which a file can be created: a probe file is created and removed.

    Raises
    ------
    InputError
        ``path`` is an existing file, lies inside another stage's output or a store
        (:func:`kernel.output_place.check_place`), or the place is read-only, not
        permitted or full.
    """
    path = check_place(path, option)
    if path.exists() and not path.is_dir():
        raise InputError(path, "exists and is not a folder", column=option,
                         expected="an output folder (created when missing)")
    _probe_write(path, option)
    return path


def check_output_file(path: str | Path, option: str = "--out") -> Path:
    """Like :func:`check_output_dir` for an output file: not a folder, parent writable."""
    path = check_place(path, option)
    if path.is_dir():
        raise InputError(path, "is a folder", column=option, expected="an output file name")
    _probe_write(path.parent, option)
    return path


def _probe_write(folder: Path, option: str) -> None:
    probe = folder
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise InputError(folder, f"{probe} is not a folder", column=option,
                         expected="a path under a folder")
    try:
        fd, tmp = tempfile.mkstemp(dir=probe, prefix=".bench-write-test-")
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        reason = WRITE_ERRNOS.get(exc.errno, exc.strerror or str(exc))
        raise InputError(folder, f"cannot write in {probe} ({reason})", column=option,
                         expected="a writable folder") from exc


#: errors of fsync on a directory that mean "not supported here", not "not on disk"
_DIR_FSYNC_UNSUPPORTED = (errno.EINVAL, errno.ENOTSUP, errno.EBADF, errno.EACCES)


def fsync_path(path: str | Path) -> None:
    """Flush a file or a directory to disk, so that a power cut keeps it whole.

    Raises
    ------
    OSError
        The flush failed (e.g. EIO): the data may not be on disk, so the caller's
        commit has failed. A directory on a file system that cannot fsync
        directories (EINVAL, ENOTSUP) is not an error.
    """
    path = Path(path)
    is_dir = path.is_dir()
    fd = os.open(path, os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if is_dir else 0))
    try:
        os.fsync(fd)
    except OSError as exc:
        if not (is_dir and exc.errno in _DIR_FSYNC_UNSUPPORTED):
            raise
    finally:
        os.close(fd)


def write_text_durable(path: str | Path, text: str) -> Path:
    """Like :func:`write_text_atomic`, the temporary file flushed to disk before the switch."""
    def write(tmp: Path) -> None:
        tmp.write_bytes(text.encode("utf-8"))
        fsync_path(tmp)

    return atomic_write(path, write)


#: integers beyond this magnitude do not convert to a float
_FLOAT_MAX = 1.7976931348623157e308


def bad_number_at(value, where: str = "") -> tuple[str, str] | None:
    """The first number of decoded TOML/JSON no float can hold: ``(key path, problem)``.

    Key paths read ``coefficients.rpm[2]``; problems are ``"non-finite number nan"``
    or ``"integer of 400 digits, too large for a number"``. None when every number
    is a finite float.
    """
    if isinstance(value, float) and not math.isfinite(value):
        return where or "<top level>", f"non-finite number {value}"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > _FLOAT_MAX:
        return where or "<top level>", (f"integer of {len(str(abs(value)))} digits, too large "
                                        "for a number")
    if isinstance(value, dict):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in value.items())
    elif isinstance(value, list):
        items = ((f"{where}[{k}]", v) for k, v in enumerate(value))
    else:
        return None
    for key, v in items:
        found = bad_number_at(v, key)
        if found is not None:
            return found
    return None
