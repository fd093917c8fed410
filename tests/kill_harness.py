"""Kill ``bench ingest`` (SIGKILL) at random moments; the store must stay old or new.

Shared by tests/test_store_atomic.py (a few dozen kills) and
benchmarks/store_kill.py (hundreds). A content digest of what the store's readers
return (manifest entries without their time stamp, points, rejected windows,
samples) identifies a store state; after every kill it must equal the digest of
the store before the ingest or of the store a complete ingest writes, and a
re-ingest must then give the complete one.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import random
import select
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
from ingest_fixtures import make_points_session, make_timeseries_session

from bench.ingest.pipeline import ingest
from bench.store.manifest import read_manifest
from bench.store.read import read_points, read_rejected, read_samples
from bench.store.schema import STAGING_PREFIX

REPO = Path(__file__).resolve().parents[1]


def _frame_digest(frame: pd.DataFrame) -> str:
    frame = frame.reset_index(drop=True)
    h = hashlib.sha256(json.dumps([list(frame.columns), [str(t) for t in frame.dtypes]])
                       .encode())
    h.update(pd.util.hash_pandas_object(frame, index=False).to_numpy().tobytes())
    return h.hexdigest()


def store_digest(store: Path) -> str:
    """SHA-256 over what the readers return; time stamps and generation names left out."""
    manifest = read_manifest(store)
    entries = {sid: {k: v for k, v in e.items() if k != "ingested_at"}
               for sid, e in manifest["sessions"].items()}
    h = hashlib.sha256(json.dumps(entries, sort_keys=True).encode())
    h.update(_frame_digest(read_points(store)).encode())
    h.update(_frame_digest(read_rejected(store)).encode())
    for sid, e in sorted(manifest["sessions"].items()):
        if e.get("kind") == "timeseries":
            h.update(_frame_digest(read_samples(store, sid)).encode())
    return h.hexdigest()


def damage_points_file(store: Path, how: str) -> Path:
    """Damage the listed ``motor_01`` points file of ``store`` as a bad disk would.

    ``how``: ``"deleted"``, ``"truncated"`` (the last 100 bytes cut) or ``"bit-rotted"``
    (one bit flipped a third of the way in). Returns the damaged file's path.
    """
    path = store / read_manifest(store)["generation"] / "points" / "motor_01.parquet"
    if how == "deleted":
        path.unlink()
    elif how == "truncated":
        path.write_bytes(path.read_bytes()[:-100])
    elif how == "bit-rotted":
        data = bytearray(path.read_bytes())
        data[len(data) // 3] ^= 0x10
        path.write_bytes(bytes(data))
    else:
        raise ValueError(f"unknown damage {how!r}")
    return path


def make_campaigns(root: Path) -> tuple[Path, Path]:
    """An old campaign and a new one: one session changed, one kept, one added."""
    old, new = root / "old", root / "new"
    make_timeseries_session(old, "motor_01", seed=1)
    make_timeseries_session(old, "gen_01", mode="generator", seed=2)
    make_points_session(old, "table_01", seed=3)
    make_timeseries_session(new, "motor_01", seed=9, setpoints=[(500.0, 20.0), (700.0, 30.0),
                                                                (900.0, 50.0)])
    make_timeseries_session(new, "gen_01", mode="generator", seed=2)
    make_points_session(new, "table_01", seed=3)
    make_timeseries_session(new, "motor_02", seed=5)
    return old, new


def ingest_command(campaign: Path, store: Path) -> list[str]:
    """The ``bench ingest`` subprocess that gets killed."""
    return [sys.executable, "-m", "drivebench.cli", "ingest", str(campaign), "--store", str(store),
            "--no-progress"]


#: os/shutil calls a child counts; it can die just before the k-th of them
_WRAP = """
import os, shutil, sys
def wrap_fs_calls(k, names):
    def wrap(mod, name):
        f = getattr(mod, name)
        def g(*a, **kw):
            names.append(name)
            if len(names) == k:
                os._exit(137)
            return f(*a, **kw)
        setattr(mod, name, g)
    for mod, name in ((os, "replace"), (os, "rename"), (os, "link"), (os, "fsync"),
                      (os, "unlink"), (os, "mkdir"), (os, "rmdir"), (os, "open"),
                      (os, "ftruncate"), (os, "write"), (shutil, "rmtree"), (shutil, "copy2")):
        wrap(mod, name)
def write_names(path, names):
    with open(path, "w") as f:  # builtins.open: not one of the counted calls
        f.write("\\n".join(names))
"""

#: a fresh interpreter running ``bench ARGS`` that dies (os._exit, as abrupt as SIGKILL:
#: no cleanup, no flush) just before its k-th file-system call (k = 0: never) and
#: writes the names of the calls it made to NAMES_FILE: argv = k NAMES_FILE ARGS
STEP_CHILD = _WRAP + """
k, names = int(sys.argv[1]), []
wrap_fs_calls(k, names)
from drivebench.cli import main
rc = main(sys.argv[3:])
write_names(sys.argv[2], names)
sys.exit(rc)
"""

#: a process that imports ``drivebench.cli`` and the modules named in argv once, then, for each
#: JSON line ``[k, names_file, args]`` on stdin, forks a child that runs ``bench ARGS`` as
#: STEP_CHILD does; it says "ready" once, then answers each child's pid and exit code
FORK_SERVER = _WRAP + """
import importlib, json
from drivebench.cli import main
for module in sys.argv[1:]:
    importlib.import_module(module)
print("ready", flush=True)
for line in sys.stdin:
    k, names_file, args = json.loads(line)
    pid = os.fork()
    if pid == 0:
        null = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(null, fd)
        names, rc = [], 1
        try:
            wrap_fs_calls(k, names)
            rc = main(args)
            write_names(names_file, names)
        finally:
            os._exit(rc if isinstance(rc, int) else 1)
    print(pid, flush=True)
    print(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), flush=True)
"""


@dataclass
class ChildRun:
    """One run of a stage in a child process."""

    rc: int
    seconds: float  # from the child's start to its end (or death)
    fs_calls: list[str] | None  # names of its file-system calls (None when it died early)


class StageRunner:
    """Runs ``bench ARGS`` in child processes that can die at a chosen moment.

    ``preload=None``: each run is a fresh interpreter (``python -c STEP_CHILD``), so a
    kill can also land in its start-up. ``preload=[module, ...]``: one fork server
    imports ``drivebench.cli`` and these modules once and forks each run from itself, so the
    runs skip the imports and a kill lands in the stage's own work; use it as a
    context manager.
    """

    def __init__(self, work: Path, preload: list[str] | None = None) -> None:
        self.work = work
        self.work.mkdir(parents=True, exist_ok=True)
        self.env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        self.server = None if preload is None else subprocess.Popen(
            [sys.executable, "-c", FORK_SERVER, *preload], cwd=REPO, env=self.env,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0)
        if self.server is not None:
            assert self._line() == "ready\n"
        self._count = 0

    def __enter__(self) -> StageRunner:
        return self

    def __exit__(self, *exc) -> None:
        if self.server is not None:
            self.server.stdin.close()
            self.server.wait(timeout=60)

    def _line(self, timeout: float | None = None) -> str | None:
        """The server's next line, or None when none came within ``timeout`` seconds."""
        out, data = self.server.stdout, b""
        while not data.endswith(b"\n"):
            if timeout is not None and not select.select([out], [], [], timeout)[0]:
                assert not data
                return None
            chunk = out.read(1)
            assert chunk, f"fork server ended (exit {self.server.wait()})"
            data += chunk
            timeout = None
        return data.decode()

    def run(self, args: list[str], step: int = 0, kill_after: float | None = None) -> ChildRun:
        """Run ``bench ARGS``; die before file-system call ``step`` (0: never), or get a
        SIGKILL ``kill_after`` seconds after the start when still running."""
        self._count += 1
        names_file = self.work / f"fs_calls_{self._count}.txt"
        t0 = time.perf_counter()
        if self.server is None:
            proc = subprocess.Popen([sys.executable, "-c", STEP_CHILD, str(step),
                                     str(names_file), *args], cwd=REPO, env=self.env,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            if kill_after is not None:
                try:
                    proc.wait(timeout=kill_after)
                except subprocess.TimeoutExpired:
                    proc.send_signal(signal.SIGKILL)
            rc = proc.wait()
        else:
            self.server.stdin.write((json.dumps([step, str(names_file), args]) + "\n").encode())
            pid = int(self._line())
            line = None if kill_after is None else self._line(timeout=kill_after)
            if line is None and kill_after is not None:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
            rc = int(line if line is not None else self._line())
        seconds = time.perf_counter() - t0
        names = names_file.read_text().split("\n") if names_file.exists() else None
        return ChildRun(rc, seconds, names)


def kill_steps(names: list[str], steps: int | None, around_switches: bool) -> list[int]:
    """File-system calls (1-based) to die before: ``steps`` spread evenly over all of them
    (None: every one), and with ``around_switches`` the one before and the one after each
    rename, replace or tree removal, where a write's visible state switches."""
    total = len(names)
    ks = set(range(1, total + 1)) if steps is None else {
        1 + round(i * (total - 1) / max(steps - 1, 1)) for i in range(steps)}
    if around_switches:
        ks |= {k + d for k, name in enumerate(names, start=1)
               if name in ("rename", "replace", "rmtree") for d in (0, 1) if k + d <= total}
    return sorted(ks)


@dataclass
class KillFigures:
    """What a kill run saw."""

    tried: int = 0
    fs_steps: int = 0  # of which: died just before a chosen file-system call
    killed_old: int = 0  # store still the old one
    killed_new: int = 0  # the commit had completed
    finished: int = 0  # ingest ended before the kill
    neither: int = 0  # store neither old nor new (goal: 0)
    staging_left: int = 0  # killed while a staging folder existed (processing or commit)
    two_generations: int = 0  # killed between the new generation's rename and the old one's removal
    not_converged: int = 0  # re-ingest did not give the new store (goal: 0)
    leftovers: int = 0  # staging/generation folders left after the re-ingest (goal: 0)
    full_run_s: float = 0.0
    problems: list[str] = field(default_factory=list)


class _Setup:
    """The old store, the new campaign and the two digests every kill is checked against."""

    def __init__(self, work: Path, runner: StageRunner) -> None:
        old_campaign, self.new_campaign = make_campaigns(work / "camp")
        self.base = work / "old_store"
        ingest([old_campaign], self.base, progress=False)
        self.old_digest = store_digest(self.base)
        ref = work / "ref_store"
        shutil.copytree(self.base, ref)
        full = runner.run(self.args(ref))
        assert full.rc == 0, f"uninterrupted ingest: exit {full.rc}"
        self.full_run_s, self.fs_calls = full.seconds, full.fs_calls
        self.new_digest = store_digest(ref)
        assert self.new_digest != self.old_digest

    def args(self, store: Path) -> list[str]:
        return ingest_command(self.new_campaign, store)[3:]


def run_kills(work: Path, n: int, seed: int = 0, steps: int | None = 0,
              log=lambda msg: None, fork: bool = False,
              around_switches: bool = False) -> KillFigures:
    """Kill ``n`` ingests of the new campaign into copies of the old store, then more.

    Half the ``n`` SIGKILL moments are uniform over the whole run, half uniform
    over its last 40 % where the commit is. Then an ingest dies just before its
    k-th file-system call, for ``steps`` values of k spread evenly over all its
    calls (None: every k) and, with ``around_switches``, for the calls just before
    and after each rename, replace and tree removal, so every step of the commit is
    hit, which random timing rarely does. ``fork``: the ingests are forked from a
    process that has imported them (StageRunner), so a SIGKILL lands in the ingest's
    work rather than in the interpreter's start-up (parsing, processing, commit).
    """
    preload = ["bench.ingest.pipeline", "bench.ingest.cli"] if fork else None
    with StageRunner(work / "runner", preload) as runner:
        return _kill_ingests(work, runner, n, seed, steps, around_switches, log)


def _kill_ingests(work, runner, n, seed, steps, around_switches, log) -> KillFigures:
    setup = _Setup(work, runner)
    base, new_campaign = setup.base, setup.new_campaign
    old_digest, new_digest = setup.old_digest, setup.new_digest
    figures = KillFigures(full_run_s=setup.full_run_s)
    rng = random.Random(seed)
    plan = [("time", None)] * n + [("step", k) for k in kill_steps(setup.fs_calls, steps,
                                                                   around_switches)]
    for k, (how, step) in enumerate(plan):
        store = work / f"store_{k}"
        shutil.copytree(base, store)
        full = figures.full_run_s
        delay = rng.uniform(0, full) if k % 2 == 0 else rng.uniform(0.6 * full, 1.05 * full)
        if how == "time":
            rc = runner.run(setup.args(store), kill_after=delay).rc
        else:
            delay = float(step)
            rc = runner.run(setup.args(store), step=step).rc
        figures.tried += 1
        figures.fs_steps += how == "step"
        digest = store_digest(store)
        left = [p.name for p in store.iterdir()]
        figures.staging_left += any(x.startswith(STAGING_PREFIX) for x in left)
        figures.two_generations += sum(x.startswith("gen-") for x in left) > 1
        if rc == 0:
            figures.finished += 1
        if digest == old_digest:
            figures.killed_old += rc != 0
        elif digest == new_digest:
            figures.killed_new += rc != 0
        else:
            figures.neither += 1
            figures.problems.append(f"kill {k} ({how} {delay:.3f}): store neither old nor new")
        ingest([new_campaign], store, progress=False, notify=lambda line: None)
        if store_digest(store) != new_digest:
            figures.not_converged += 1
            figures.problems.append(f"kill {k} ({how} {delay:.3f}): re-ingest did not converge")
        names = sorted(p.name for p in store.iterdir())
        if any(x.startswith(STAGING_PREFIX) for x in names) or \
                len([x for x in names if x.startswith("gen-")]) != 1:
            figures.leftovers += 1
            figures.problems.append(f"kill {k}: leftovers {names}")
        shutil.rmtree(store)
        log(f"kill {k + 1}/{len(plan)} ({how} {delay:.3f}): rc {rc}, "
            f"{'old' if digest == old_digest else 'new' if digest == new_digest else 'NEITHER'}")
    return figures


# -- stage output folders (bench fit, bench optimize, ...) ------------------------------

def folder_files(folder: Path) -> dict[str, str]:
    """Relative path -> SHA-256 of every file under ``folder`` (empty when it is missing)."""
    if not folder.is_dir():
        return {}
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@dataclass
class OutputKillFigures:
    """What a kill run of a stage writing an output folder saw."""

    tried: int = 0
    fs_steps: int = 0  # of which: died just before a chosen file-system call
    old: int = 0  # the folder is byte for byte the old output
    new: int = 0  # the folder is one whole new output (run.json checks, new run id)
    finished: int = 0  # the stage ended before the kill
    mixed: int = 0  # neither (goal: 0)
    refused_by_readers: int = 0  # of the mixed: check_output_folder refuses them
    staging_left: int = 0  # killed while a staging folder existed beside the output
    leftovers: int = 0  # staging folders left after the next complete run (goal: 0)
    full_run_s: float = 0.0
    problems: list[str] = field(default_factory=list)


def run_output_kills(work: Path, old_args: list[str], new_args: list[str], n: int,
                     steps: int | None, seed: int = 0, log=lambda msg: None,
                     preload: list[str] | None = None,
                     around_switches: bool = False) -> OutputKillFigures:
    """Kill a stage (``bench <new_args> --out DIR``) writing over an earlier output.

    ``old_args``/``new_args`` are the stage's command lines without ``--out``; the
    old one writes the folder first. Then ``n`` SIGKILLs at a moment uniform over the
    run, and deaths just before the k-th file-system call for ``steps`` values of k
    spread over all calls (None: every k) and, with ``around_switches``, just before
    and after each rename, replace and tree removal. After each kill the folder must
    be exactly the old output or one whole new one; the next complete run, in the
    last folder a kill left a staging folder beside, must remove it. ``preload``:
    the runs are forked from a process that has imported these modules
    (StageRunner), so a SIGKILL lands in the stage's work, not in its start-up.
    """
    with StageRunner(work / "runner", preload) as runner:
        return _kill_outputs(work, runner, old_args, new_args, n, steps, seed,
                             around_switches, log)


def _kill_outputs(work, runner, old_args, new_args, n, steps, seed, around_switches,
                  log) -> OutputKillFigures:
    from kernel.output_folder import RUN_FILE, check_output_folder

    base = work / "base" / "out"
    assert runner.run([*old_args, "--out", str(base)]).rc == 0, "the old output"
    old = folder_files(base)
    old_run = json.loads((base / RUN_FILE).read_text())["run_id"]
    ref = work / "ref" / "out"
    shutil.copytree(base, ref)
    full = runner.run([*new_args, "--out", str(ref)])
    assert full.rc == 0, f"uninterrupted run: exit {full.rc}"
    figures = OutputKillFigures(full_run_s=full.seconds)
    new_names = set(folder_files(ref))
    rng = random.Random(seed)
    plan = [("time", None)] * n + [("step", k) for k in kill_steps(full.fs_calls, steps,
                                                                   around_switches)]
    dirty = None  # the last output folder a kill left a staging folder beside
    for i, (how, step) in enumerate(plan):
        out = work / f"kill_{i}" / "out"
        shutil.copytree(base, out)
        if how == "time":
            delay = rng.uniform(0, 1.05 * figures.full_run_s)
            rc = runner.run([*new_args, "--out", str(out)], kill_after=delay).rc
        else:
            delay = float(step)
            rc = runner.run([*new_args, "--out", str(out)], step=step).rc
        figures.tried += 1
        figures.fs_steps += how == "step"
        figures.finished += rc == 0
        now = folder_files(out)
        state = "old" if now == old else "mixed"
        if state == "mixed" and set(now) == new_names:
            try:
                run_id = check_output_folder(out)
            except Exception:  # noqa: BLE001 - any refusal counts as refused
                run_id = None
            state = "new" if run_id not in (None, old_run) else "mixed"
        if state == "mixed":
            figures.mixed += 1
            try:
                check_output_folder(out)
            except Exception:  # noqa: BLE001
                figures.refused_by_readers += 1
            figures.problems.append(f"kill {i} ({how} {delay:.3f}): folder mixed: "
                                    f"{sorted(set(now) ^ set(old))[:5]}")
        else:
            setattr(figures, state, getattr(figures, state) + 1)
        if any(p.name.startswith(".out.") for p in out.parent.iterdir()):
            figures.staging_left += 1
            dirty = out
        elif out != dirty:
            shutil.rmtree(out.parent)
        log(f"kill {i + 1}/{len(plan)} ({how} {delay:.3f}): rc {rc}, {state}")
    if dirty is not None:
        assert runner.run([*new_args, "--out", str(dirty)]).rc == 0, "the next complete run"
        # the writer's lock file (kernel.locking) stays beside the output, as the store's does
        left = sorted(p.name for p in dirty.parent.iterdir() if p.name not in ("out", ".out.lock"))
        if left:
            figures.leftovers += 1
            figures.problems.append(f"after the next run: leftovers {left}")
    return figures
