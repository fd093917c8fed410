"""The report's provenance section: package versions, input file hashes, command lines, date."""

from __future__ import annotations

import platform
import shlex
from datetime import UTC, datetime

from kernel.provenance import command_text, read_header
from kernel.versions import ipopt_version, package_versions
from reports.inputs import InputLog

#: the keys under which a stage's document records its command line (a list or a string)
COMMAND_KEYS = ("command_line", "command")


def stage_row(stage: str, doc: dict | None, run_id: str | None) -> dict:
    """One row of the command-line table: the stage's own command line, run id and date as
    its output records them (its provenance header, else the top-level or ``provenance``
    keys of older files)."""
    if not isinstance(doc, dict):
        return {"stage": stage, "command": "not run (no output found)", "run_id": "",
                "created": ""}
    header = read_header(doc)
    if header is not None:  # the one provenance header every stage writes
        return {"stage": stage, "command": command_text(header), "run_id": header["run_id"],
                "created": str(header["created_utc"])}
    places = [doc.get("provenance_header"), doc, doc.get("provenance")]
    command = created = None
    for place in (p for p in places if isinstance(p, dict)):
        for key in COMMAND_KEYS:
            value = place.get(key)
            if command is None and value:
                command = shlex.join(map(str, value)) if isinstance(value, list) else str(value)
        created = created or place.get("created_utc") or place.get("created_at")
        run_id = run_id or place.get("run_id")
    return {"stage": stage, "command": command or "not recorded in the stage's files",
            "run_id": run_id or "", "created": str(created or "")}


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
        Stage name -> (its output folder, the decoded document that records how it ran:
        store manifest, power model, optimize manifest, aep.json, sizing.json); one row
        each in the command-line table (:func:`stage_row`).

    Returns
    -------
    dict
        ``date``, ``commands``, ``packages``, ``inputs``, ``raw_files``, ``platform``,
        ``runs`` (stage output folders read and their run ids).
    """
    commands = [stage_row(stage, doc, log.runs.get(str(folder)) if folder else None)
                for stage, (folder, doc) in stage_metadata.items()]
    commands.append({"stage": "report", "command": shlex.join(argv), "run_id": "",
                     "created": started.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%S+00:00")})
    raw = []
    manifest = (stage_metadata.get("ingest") or (None, None))[1]
    if isinstance(manifest, dict) and isinstance(manifest.get("sessions"), dict):
        for sid, entry in sorted(manifest["sessions"].items()):
            files = entry.get("files") if isinstance(entry, dict) else None
            for name, digest in sorted((files or {}).items()):
                raw.append({"session_id": str(sid), "path": str(name), "sha256": str(digest)})
    return {
        "date": started.astimezone(UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "commands": commands,
        "packages": [*package_versions().items(), ("IPOPT (the library CasADi loads)",
                                                     ipopt_version())],
        "platform": f"{platform.system()} {platform.machine()}",
        "inputs": [
            {"path": r.path, "sha256": r.sha256, "size_bytes": r.size_bytes} for r in log.records
        ],
        "missing": list(dict.fromkeys(log.missing)),
        "raw_files": raw,
        "runs": [{"folder": folder, "run_id": run_id} for folder, run_id in log.runs.items()
                 if run_id is not None],
    }
