"""The provenance header of every stage's record: when, by which command line, which run,
with which versions (docs/schemas.md "Provenance header").

Each stage makes one :class:`Provenance` when it starts and writes :meth:`Provenance.header`
under the key :data:`HEADER_KEY` of its record (the store manifest, ``fit_summary.json``,
the optimize manifest, ``aep.json``, ``sizing.json``) and of its folder's ``run.json``
(:func:`kernel.output_folder.output_folder`), so the two name the same run.
"""

from __future__ import annotations

import shlex
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from kernel.errors import InputError
from kernel.versions import package_versions

#: the key of the header in every stage's record
HEADER_KEY = "provenance"
#: the keys of the header, each always present
HEADER_FIELDS = ("created_utc", "command_line", "run_id", "versions")


@dataclass(frozen=True)
class Provenance:
    """Who made a stage's output: one run of one command.

    Attributes
    ----------
    command_line : tuple of str
        The command line as given (``("bench", "fit", "--order", "2")``), or the Python
        call's name (``("drivebench.fit",)``).
    run_id : str
        A new UUID4 (hex) per run; the same in the record and the folder's ``run.json``.
    created_utc : str
        When the run started, ISO 8601 in UTC to the second.
    versions : dict
        Python's and the result-relevant packages' versions
        (:func:`kernel.versions.package_versions`).
    """

    command_line: tuple[str, ...]
    run_id: str = field(default_factory=lambda: uuid.uuid4().hex)
    created_utc: str = field(
        default_factory=lambda: datetime.now(UTC).isoformat(timespec="seconds"))
    versions: dict = field(default_factory=package_versions)

    @classmethod
    def start(cls, command_line: Sequence[str]) -> Provenance:
        """The provenance of a run starting now with ``command_line``."""
        return cls(tuple(str(a) for a in command_line))

    def header(self) -> dict:
        """The header as every record writes it (JSON-ready)."""
        return {"created_utc": self.created_utc, "command_line": list(self.command_line),
                "run_id": self.run_id, "versions": dict(self.versions)}


def read_header(record: object, path: str | Path | None = None) -> dict | None:
    """The provenance header of a decoded stage record (its :data:`HEADER_FIELDS`; a record
    may add keys of its own), or None when it has none (written before the header existed).

    Raises
    ------
    InputError
        The header is there but lacks a field or has a field of the wrong type.
    """
    header = record.get(HEADER_KEY) if isinstance(record, dict) else None
    if header is None:
        return None
    types = {"created_utc": str, "command_line": list, "run_id": str, "versions": dict}
    for key, typ in types.items():
        if not isinstance(header, dict) or not isinstance(header.get(key), typ):
            raise InputError(path, f"provenance header without a valid {key!r}",
                             column=f"{HEADER_KEY}.{key}",
                             expected="the header of docs/schemas.md (Provenance header)")
    return {key: header[key] for key in HEADER_FIELDS}


def command_text(header: dict) -> str:
    """The header's command line as one shell-quoted line."""
    return shlex.join(map(str, header["command_line"]))
