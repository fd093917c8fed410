"""Reading the stage outputs the report is built from, and remembering what was read.

The report only reads files (docs/schemas.md §2, §4, §5). Each read goes through
:class:`InputLog`, which records the file's SHA-256 for the provenance section and
the files that were expected but missing, so every section can say what it lacks.
A file that is present but unreadable is bad input: :class:`kernel.errors.InputError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from kernel.errors import InputError
from kernel.files import file_sha256, read_json
from kernel.output_folder import check_output_file


@dataclass(frozen=True)
class InputRecord:
    """One input file the report read.

    Parameters
    ----------
    path : str
        The file as given on the command line side (not resolved).
    sha256 : str
        SHA-256 of the file's bytes (hex).
    size_bytes : int
        File size [bytes].
    """

    path: str
    sha256: str
    size_bytes: int


class InputLog:
    """Reads input files and records each one (hash) or its absence.

    Attributes
    ----------
    records : list of InputRecord
        Files read, in order.
    missing : list of str
        Files (or folders) looked for but absent.
    runs : dict
        Stage output folder -> its run id (None: written before run ids); each
        folder is checked to be the whole output of one run before its first file
        is read (:func:`kernel.output_folder.check_output_folder`).
    """

    def __init__(self) -> None:
        self.records: list[InputRecord] = []
        self.missing: list[str] = []
        self.runs: dict[str, str | None] = {}

    def _present(self, path: Path) -> bool:
        if path.is_file():
            if str(path.parent) not in self.runs:
                self.runs[str(path.parent)] = check_output_file(path)
            return True
        self.missing.append(str(path))
        return False

    def _record(self, path: Path) -> None:
        if all(r.path != str(path) for r in self.records):
            self.records.append(InputRecord(str(path), file_sha256(path), path.stat().st_size))

    def json(self, path: Path) -> dict | None:
        """Decoded JSON object of ``path``, or None if the file is missing.

        Raises
        ------
        InputError
            If the file is not valid JSON or not a JSON object.
        """
        path = Path(path)
        if not self._present(path):
            return None
        data = read_json(path, what="JSON file")
        if not isinstance(data, dict):
            raise InputError(path, "top level is not a JSON object", expected="a JSON object")
        self._record(path)
        return data

    def parquet(self, path: Path, required: tuple[str, ...] = ()) -> pd.DataFrame | None:
        """Frame of one Parquet file, or None if missing.

        Parameters
        ----------
        path : Path
            The Parquet file.
        required : tuple of str
            Columns that must be present.

        Raises
        ------
        InputError
            If the file is not Parquet or lacks a required column.
        """
        path = Path(path)
        if not self._present(path):
            return None
        try:
            frame = pq.read_table(path).to_pandas()
        except (pa.ArrowException, OSError) as exc:
            raise InputError(path, f"not a readable Parquet file: {exc}") from exc
        _require(frame, required, path)
        self._record(path)
        return frame

    def parquet_files(self, files: list[Path], label: str,
                      required: tuple[str, ...] = ()) -> pd.DataFrame | None:
        """The given Parquet files concatenated, or None (``label`` missing) if there are none."""
        if not files:
            self.missing.append(label)
            return None
        frames = [self.parquet(Path(f), required) for f in files]
        return pd.concat(frames, ignore_index=True)

    def csv(self, path: Path, required: tuple[str, ...] = ()) -> pd.DataFrame | None:
        """Frame of a CSV file (English locale), or None if missing."""
        path = Path(path)
        if not self._present(path):
            return None
        try:
            frame = pd.read_csv(path, keep_default_na=False)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
            raise InputError(path, f"not a readable CSV file: {exc}") from exc
        _require(frame, required, path)
        self._record(path)
        return frame


def _require(frame: pd.DataFrame, required: tuple[str, ...], path: Path) -> None:
    for column in required:
        if column not in frame.columns:
            raise InputError(
                path, "missing column", column=column, expected=", ".join(required)
            )
