"""File writers for a synthetic campaign, in the layouts of docs/schemas.md section 1.

Every file goes to a temporary path in its own directory and is moved into place
with ``os.replace`` only once complete, so an interrupted run never leaves a
half-written file under its final name.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from bench.synth.numfmt import format_rows
from kernel.files import commit, discard, temp_path


def toml_value(value) -> str:
    """One TOML value: strings as basic strings (JSON escapes are valid TOML), numbers as is."""
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def toml_document(top: dict, tables: dict[str, dict]) -> str:
    """A flat TOML document: ``top`` keys, then one ``[table]`` per entry of ``tables``."""
    lines = [f"{k} = {toml_value(v)}" for k, v in top.items()]
    for name, table in tables.items():
        lines.append("")
        lines.append(f"[{name}]")
        lines.extend(f"{k} = {toml_value(v)}" for k, v in table.items())
    return "\n".join(lines) + "\n"


class CsvStream:
    """Chunked writer of a CSV file: a fixed preamble, then formatted rows.

    Parameters
    ----------
    path : Path
        Final file path (written atomically on :meth:`close`).
    preamble : str
        Everything before the first data row (header block, names row, units row).
    decimals : sequence of int
        Digits after the decimal mark per column.
    sep : str
        Field separator.
    decimal_mark : str
        Decimal mark.
    """

    def __init__(self, path: Path, preamble: str, decimals, sep=",", decimal_mark="."):
        self._path = Path(path)
        self._tmp = temp_path(self._path)
        self._fh = open(self._tmp, "wb")
        self._fh.write(preamble.encode("utf-8"))
        self._decimals = list(decimals)
        self._sep = sep
        self._mark = decimal_mark

    def write(self, columns, markers=None) -> None:
        """Append rows; ``markers`` as in :func:`bench.synth.numfmt.format_rows`."""
        self._fh.write(
            format_rows(columns, self._decimals, sep=self._sep,
                        decimal_mark=self._mark, markers=markers)
        )

    def close(self, ok: bool = True) -> None:
        """Finish the file; with ``ok=False`` discard it."""
        self._fh.close()
        if ok:
            commit(self._tmp, self._path)
        else:
            discard(self._tmp)


class TdmsStream:
    """Chunked NI TDMS writer: one group, channels with a ``unit_string`` property.

    Parameters
    ----------
    path : Path
        Final file path (written atomically on :meth:`close`).
    group : str
        TDMS group name.
    channels : sequence of (str, str)
        ``(channel name, unit_string)`` in column order.
    properties : dict
        Root properties (plain strings and numbers only, so the file is reproducible).
    """

    def __init__(self, path: Path, group: str, channels, properties: dict):
        self._path = Path(path)
        self._tmp = temp_path(self._path)
        self._writer = TdmsWriter(str(self._tmp))
        self._writer.open()
        self._group = group
        self._channels = list(channels)
        self._first = True
        self._properties = dict(properties)

    def write(self, columns) -> None:
        """Append one segment holding the next rows of every channel (float64)."""
        objects = []
        if self._first:
            objects += [RootObject(properties=self._properties), GroupObject(self._group)]
        for (name, unit), col in zip(self._channels, columns, strict=True):
            props = {"unit_string": unit} if self._first else {}
            objects.append(ChannelObject(self._group, name, np.asarray(col, dtype=np.float64),
                                         properties=props))
        self._writer.write_segment(objects)
        self._first = False

    def close(self, ok: bool = True) -> None:
        """Finish the file; with ``ok=False`` discard it."""
        self._writer.close()
        if ok:
            commit(self._tmp, self._path)
        else:
            discard(self._tmp)
