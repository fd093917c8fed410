"""Where an output may go: never inside another stage's output folder or a store.

Every stage's output folder is written whole and checked whole by its readers
(:mod:`kernel.output_folder`): a file put inside it by another command (``bench aep
--out opt/aep``, ``bench cycle export --out opt/profile.csv``) makes it "mixed or
altered" for every later reader. The store's manifest lists its files likewise. So the
``--out`` (``--store``) of every stage is refused, before anything is created, when a
folder above it is one of those: it holds ``run.json`` (a stage's run record) or a
``manifest.json`` of a drivebench schema (the store's, or a sweep's written before run
records).
"""

from __future__ import annotations

import json
from pathlib import Path

from kernel.errors import InputError

#: a stage output folder's run record (:mod:`kernel.output_folder`)
RUN_FILE = "run.json"
#: its schema
RUN_SCHEMA = "drivebench.run"
#: the manifest of a store (``drivebench.store``) or of an older sweep
MANIFEST_FILE = "manifest.json"
_PREFIX = "drivebench."


def _schema(path: Path) -> str | None:
    """The ``"schema"`` of a JSON document, None when it is not one (or unreadable)."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    schema = doc.get("schema") if isinstance(doc, dict) else None
    return schema if isinstance(schema, str) else None


def owner_of(folder: str | Path) -> str | None:
    """What owns ``folder`` as its output, in words; None when nothing does.

    ``"a bench optimize output (run.json)"``, ``"a drivebench.store (manifest.json)"``.
    """
    folder = Path(folder)
    run = folder / RUN_FILE
    if run.is_file() and _schema(run) == RUN_SCHEMA:
        try:
            stage = json.loads(run.read_text(encoding="utf-8")).get("stage", "?")
        except (OSError, UnicodeDecodeError, ValueError, AttributeError):
            stage = "?"
        return f"a bench {stage} output ({RUN_FILE})"
    manifest = folder / MANIFEST_FILE
    if manifest.is_file():
        schema = _schema(manifest)
        if schema is not None and schema.startswith(_PREFIX):
            what = "store" if schema == f"{_PREFIX}store" else schema
            return f"a drivebench {what} ({MANIFEST_FILE})"
    return None


def check_place(target: str | Path, option: str = "--out", itself: bool = False) -> Path:
    """Raise InputError when a folder above ``target`` is another output's.

    Parameters
    ----------
    target : str or Path
        The output folder or file (or store) a stage is about to write.
    option : str
        The option that named it, for the message.
    itself : bool
        Check ``target`` too (a folder the stage writes into, not one it replaces).

    Returns
    -------
    Path
        ``target``.

    Raises
    ------
    InputError
        Naming ``target``, the option and the folder whose output it would land in.
    """
    target = Path(target)
    full = target.absolute().resolve()
    for folder in ([full] if itself else []) + list(full.parents):
        owner = owner_of(folder)
        if owner is not None:
            where = "is" if folder == full else f"lies inside {folder},"
            raise InputError(target, f"{where} {owner}: a file written there "
                             "makes that folder mixed for every later reader", column=option,
                             expected="a place outside every stage's output folder and store "
                             "(e.g. beside it)")
    return target
