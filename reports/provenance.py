"""Section 5 of the report: package versions, input file hashes, command lines, date."""

from __future__ import annotations

import platform
import shlex
from datetime import UTC, datetime

from kernel.provenance import command_text, read_header
from kernel.versions import package_versions
from reports.inputs import InputLog


def _commands(stage: str, record) -> list[dict]:
    """The command line of a stage's record, from its provenance header (none for a record
    written before the header)."""
    header = read_header(record)
    return [] if header is None else [{"stage": stage, "command": command_text(header),
                                       "run_id": header["run_id"],
                                       "created_utc": header["created_utc"]}]


def provenance_section(log: InputLog, argv: list[str], started: datetime,
                       stage_metadata: dict[str, object]) -> dict:
    """Provenance context: call this last, after every other section has read its files.

    Parameters
    ----------
    log : InputLog
        The log every section read through; its records are the input hashes.
    argv : list of str
        This report's command line (``bench report ...``).
    started : datetime
        When report generation started (UTC).
    stage_metadata : dict
        Stage name -> its decoded record (store manifest, ``fit_summary.json``, optimize
        manifest, ``aep.json``, ``sizing.json``) or None; the command line is read from
        its provenance header (:func:`kernel.provenance.read_header`).

    Returns
    -------
    dict
        ``date``, ``commands``, ``packages``, ``inputs``, ``raw_files``, ``platform``,
        ``runs`` (stage output folders read and their run ids).
    """
    commands = [{"stage": "report", "command": shlex.join(argv)}]
    for stage, doc in stage_metadata.items():
        commands.extend(_commands(stage, doc))
    raw = []
    manifest = stage_metadata.get("ingest")
    if isinstance(manifest, dict) and isinstance(manifest.get("sessions"), dict):
        for sid, entry in sorted(manifest["sessions"].items()):
            files = entry.get("files") if isinstance(entry, dict) else None
            for name, digest in sorted((files or {}).items()):
                raw.append({"session_id": str(sid), "path": str(name), "sha256": str(digest)})
    return {
        "date": started.astimezone(UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "commands": commands,
        "packages": list(package_versions().items()),
        "platform": f"{platform.system()} {platform.machine()}",
        "inputs": [
            {"path": r.path, "sha256": r.sha256, "size_bytes": r.size_bytes} for r in log.records
        ],
        "missing": list(dict.fromkeys(log.missing)),
        "raw_files": raw,
        "runs": [{"folder": folder, "run_id": run_id} for folder, run_id in log.runs.items()
                 if run_id is not None],
    }
