"""Damage a store four ways; print what ``bench store check`` and ``bench ingest`` say and do.

Usage::

    .venv/bin/python benchmarks/store_damage.py

A campaign of five sessions (three DAQ + analyzer time series, one generator, one
operating-point table) is ingested; then, each on a fresh copy of the store: a
listed points file deleted, truncated by 100 bytes, bit-rotted (one bit flipped),
and the manifest's generation renamed by hand (gen-000001 -> gen-000099). For each:
``bench store check`` (exit code, lines, whether any file changed), then ``bench
ingest`` of the same campaign (exit code, its lines about damage, whether the store
afterwards equals the undamaged one by a digest of what its readers return, and
whether the original generation survived until a complete one replaced it).
Exit code 1 when a damage goes unnoticed or data are lost.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from ingest_fixtures import make_points_session, make_timeseries_session  # noqa: E402
from kill_harness import REPO, damage_points_file, folder_files, store_digest  # noqa: E402

from bench.ingest.pipeline import ingest  # noqa: E402
from bench.store.manifest import read_manifest  # noqa: E402


def _bench(*args: str) -> tuple[int, str]:
    proc = subprocess.run([sys.executable, "-m", "drivebench.cli", *args], capture_output=True,
                          text=True, cwd=REPO)
    return proc.returncode, (proc.stdout + proc.stderr).strip()


def _damage(store: Path, how: str) -> str:
    if how != "manifest edited":
        path = damage_points_file(store, how)
        return f"{path.relative_to(store)} {how}"
    gen = read_manifest(store)["generation"]
    manifest = json.loads((store / "manifest.json").read_text())
    manifest["generation"] = "gen-000099"
    (store / "manifest.json").write_text(json.dumps(manifest))
    return f"manifest generation {gen} -> gen-000099"


def main() -> int:
    failures = 0
    with tempfile.TemporaryDirectory(prefix="store_damage_") as tmp:
        work = Path(tmp)
        camp = work / "camp"
        for k, sid in enumerate(("motor_01", "motor_02", "motor_03")):
            make_timeseries_session(camp, sid, seed=k + 1)
        make_timeseries_session(camp, "gen_01", mode="generator", seed=7)
        make_points_session(camp, "table_01", seed=3)
        base = work / "base"
        ingest([camp], base, progress=False)
        healthy = store_digest(base)
        for how in ("deleted", "truncated", "bit-rotted", "manifest edited"):
            store = work / how.replace(" ", "_")
            shutil.copytree(base, store)
            first_gen = read_manifest(base)["generation"]
            what = _damage(store, how)
            before = folder_files(store)
            rc, text = _bench("store", "check", "--store", str(store))
            unchanged = folder_files(store) == before
            print(f"== {what}")
            print(f"bench store check: exit {rc}, store {'unchanged' if unchanged else 'CHANGED'}")
            print("   " + "\n   ".join(text.splitlines()))
            rc2, text2 = _bench("ingest", str(camp), "--store", str(store), "--no-progress")
            said = [ln for ln in text2.splitlines() if "damaged" in ln or "repaired" in ln
                    or "generation" in ln]
            restored = rc2 == 0 and store_digest(store) == healthy
            print(f"bench ingest: exit {rc2}; store equals the undamaged one: {restored}; "
                  f"generations now: {sorted(p.name for p in store.glob('gen-*'))} "
                  f"(the original {first_gen} kept until then)")
            print("   " + "\n   ".join(said))
            rc3, _ = _bench("store", "check", "--store", str(store))
            print(f"bench store check afterwards: exit {rc3}\n")
            failures += rc != 1 or not unchanged or not restored or rc3 != 0
    print(f"{failures} of 4 damages unnoticed or not repaired (goal 0)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
