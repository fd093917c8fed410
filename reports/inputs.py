"""Reading the stage outputs the report is built from, and remembering what was read.

The report only reads files (docs/schemas.md §2, §4, §5, §7, §8), each through the reader
of the stage that writes it (``bench.store``, ``fitting.fit_folder``,
``optimize.sweep_folder``, ``energy.outputs``, ``energy.sizing_files``). Each read goes
through :class:`InputLog`, which records the file's SHA-256 for the provenance section and
the files that were expected but missing, so every section can say what it lacks.
A file that is present but unreadable is bad input: :class:`kernel.errors.InputError`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from kernel.files import file_sha256
from kernel.output_folder import check_output_file

T = TypeVar("T")


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

    def _present(self, path: Path, whole: bool = True) -> bool:
        if path.is_file():
            if whole and str(path.parent) not in self.runs:
                self.runs[str(path.parent)] = check_output_file(path)
            return True
        self.missing.append(str(path))
        return False

    def _record(self, path: Path) -> None:
        if all(r.path != str(path) for r in self.records):
            self.records.append(InputRecord(str(path), file_sha256(path), path.stat().st_size))

    def read(self, folder: Path, name: str, reader: Callable[[Path], T],
             whole: bool = True) -> T | None:
        """``reader(folder)``: the file ``name`` of a stage's output ``folder`` read by
        that stage's own reader, or None if the file is missing. ``whole``: the folder is
        checked to be the whole output of one run first (not the store, which its own
        reader checks against its manifest).

        Raises
        ------
        InputError
            From ``reader``: the file is present but not what its stage writes.
        """
        path = Path(folder) / name
        if not self._present(path, whole):
            return None
        value = reader(Path(folder))
        self._record(path)
        return value

    def read_files(self, files: list[Path], label: str,
                   reader: Callable[[], T]) -> T | None:
        """``reader()`` of a set of ``files`` read together (the store's tables, which its
        reader checks against its manifest), each recorded; None (``label`` missing) if
        there are none."""
        if not files:
            self.missing.append(label)
            return None
        value = reader()
        for path in files:
            self._record(Path(path))
        return value
