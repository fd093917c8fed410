"""Section 5 of the report: package versions, input file hashes, command lines, date."""

from __future__ import annotations

import platform
import shlex
from datetime import UTC, datetime

from kernel.versions import package_versions
from reports.inputs import InputLog


def _commands(source: str, data) -> list[dict]:
    """Every string value under a key that names a command line, found recursively."""
    out = []
    if isinstance(data, dict):
        for key, value in data.items():
            if "command" in str(key).lower() or str(key).lower() in ("argv", "cmdline"):
                text = shlex.join(map(str, value)) if isinstance(value, list) else str(value)
                out.append({"stage": source, "command": text})
            else:
                out.extend(_commands(source, value))
    return out


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
        Stage name -> a decoded document (store manifest, model provenance,
        optimize manifest) searched for the command lines the stages recorded.

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
