"""A shipped solution to start a chain from, in place of the homotopy.

``optimize/data/initial_guess.npz`` holds the scaled primal and dual solution of
one scenario (:data:`GUESS_SCENARIO`, elec-lim-7.0, solved by the homotopy with
the paper's Table I drive model, the shipped ``highwind.toml`` system, at the default
discretization), the NLP parameters it was solved with, the scaled constraint values
``g(w, p)`` there, the system's hash, and the parts of the OCP it solved with their
variables (``parts``, ``part_variables``: :func:`parts_record`).

:func:`load` accepts the file for an OCP only if the OCP has every part the file
records, with the same variables, its system (when it has one) is the stored one, and
the OCP of those parts evaluates the same ``g`` at the stored point to :data:`MATCH_TOL`.
The check runs on the file's own mesh (:func:`optimize.problem.ocp.on_mesh`); an OCP on
another mesh gets the stored solution interpolated in time onto its own
(:func:`interpolated`). On the paper's kite at 7-10 m/s, 8 to 80 intervals, that start
took 18-43 iterations where the homotopy took 97-193 (1.3 to 5.6 times less wall time,
the check on the stored mesh included) and reached the homotopy's optimum in 4 of 6
cases; in 2 (at 10 m/s, a wind speed off the stored 7 m/s, as the stored guess starts
any wind speed on its own mesh) another local optimum 0.4 % poorer
(``benchmarks/interpolated_guess.py``).
The constraints do not depend on the drive model, so the guess serves any fitted model;
a part the OCP has beyond the file's fills its own variables along it; a part the
file records and the OCP has not, a changed kite model, scaling, collocation or layout
makes it stale, and :func:`optimize.solve.starts.cold.start` falls back to the homotopy
(saying why, once per run however many worker processes find it). Regenerate the file with::

    .venv/bin/python -m optimize.solve.starts.stored_guess

The file records the SHA-256 of its content (:data:`HASH_KEY`): an edited, truncated or
damaged file, or one without its parts record or hash, is not used, and the run says so
as a warning, once, before any solve (:func:`checked_options`: the service's problems are
made with it) and the cold starts run the homotopy. A file
written before it recorded its parts or hash gets them, checked on the OCP of the parts
named, with ``--record-parts kite,drive`` (its arrays unchanged); names that are no part
of the OCP, or none, are refused (exit 2) and the file is left as it was.
"""

from __future__ import annotations

import argparse
import dataclasses
import errno
import hashlib
import logging
import os
import socket
import sys
import zipfile
from pathlib import Path

import numpy as np

from kernel.errors import InputError
from kernel.files import atomic_path, check_output_file
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import Ocp, assemble, build_ocp, on_mesh, twin
from optimize.problem.options import OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.result import OcpResult, Solution, carry_over
from optimize.solve.starts.fill import KEYS
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.solve.starts.remesh import interpolate_multipliers, interpolate_solution
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

log = logging.getLogger(__name__)

#: the shipped file
GUESS_PATH = Path(__file__).resolve().parents[2] / "data" / "initial_guess.npz"
#: the scenario it holds: its solution warm-starts both objectives at 7 m/s
GUESS_SCENARIO = Scenario(wind_speed_m_s=7.0, objective="electrical", drive_limits=True)
#: largest deviation of the scaled constraint values at the stored point [-]
MATCH_TOL = 1e-9
#: the arrays of the file besides its scalars and its parts record
ARRAYS = ("w", "lam_x", "lam_g", "p", "g")
#: the kinds of a part's variables the record lists
RECORDED = (*KEYS, "parameters")
#: the command that writes the shipped file again
REGENERATE = "python -m optimize.solve.starts.stored_guess"
#: how a refusal of a guess of another system begins (no warning: expected for other systems)
OTHER_SYSTEM = "the stored initial guess is for another system"
#: the entry holding the SHA-256 of every other entry (:func:`content_sha256`)
HASH_KEY = "content_sha256"
#: the reasons already said as warnings in this process (each once)
_SAID: set[str] = set()
#: the names this process holds, one per reason it said first in its run (:func:`_first_in_run`)
_HELD: list[socket.socket] = []


def content_sha256(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 (hex) of a guess file's entries but :data:`HASH_KEY`: each entry's name,
    dtype, shape and bytes, in name order."""
    digest = hashlib.sha256()
    for name in sorted(k for k in arrays if k != HASH_KEY):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        digest.update(a.tobytes())
    return digest.hexdigest()


def _save(fh, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` with their content hash (:data:`HASH_KEY`) to the open file ``fh``."""
    arrays = {k: np.asarray(v) for k, v in arrays.items() if k != HASH_KEY}
    np.savez_compressed(fh, **arrays, **{HASH_KEY: np.array(content_sha256(arrays))})


def parts_record(ocp: Ocp) -> dict[str, np.ndarray]:
    """What the file records of ``ocp``'s parts: ``parts`` (their names, in order) and
    ``part_variables`` (``"<part> <kind> <variable>"`` for each variable of each kind of
    :data:`RECORDED`, in order)."""
    parts = getattr(ocp.formulation, "parts", ())
    return {"parts": np.array([p.name for p in parts], dtype=str),
            "part_variables": np.array([f"{p.name} {kind} {name}" for p in parts
                                        for kind in RECORDED
                                        for name in getattr(p, kind).names], dtype=str)}


def write(path: str | Path, ocp: Ocp, result: OcpResult, p: np.ndarray) -> Path:
    """Store ``result``'s solution with its parameters ``p``, ``g(w, p)``, the parts
    of ``ocp`` (:func:`parts_record`) and the hash of it all (:data:`HASH_KEY`; atomic)."""
    warm = result.warm
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        _save(fh, dict(
            w=warm.w, lam_x=warm.lam_x, lam_g=warm.lam_g, p=p,
            g=ocp.constraint_values(warm.w, p), n_intervals=ocp.n_intervals,
            degree=ocp.coll.degree, scenario=result.scenario.name,
            system_sha256=getattr(ocp.system, "sha256", ""), **parts_record(ocp),
        ))
    return Path(path)


def reference(ocp: Ocp, names: tuple[str, ...]) -> Ocp:
    """The OCP the stored file is checked against: ``ocp`` in the general (IPOPT)
    layout with only its parts named ``names`` (the file's); ``ocp`` itself when it is
    that (built once, cached on ``ocp``)."""
    general = twin(ocp, "ipopt")
    parts = getattr(general.formulation, "parts", ())
    kept = tuple(p for p in parts if p.name in names)
    if len(kept) == len(parts):
        return general
    key = ("stored parts", names)
    if key not in general.solvers:
        form = dataclasses.replace(general.formulation, parts=kept)
        if not form.objective_averages:  # nothing to optimize: no OCP, no optimum to check
            givers = [p.name for p in parts if p.objective_averages]
            raise ValueError(f"without the part{'s' * (len(givers) > 1)} "
                             f"{', '.join(givers)} the cycle has no objective: the average "
                             "powers it weighs come from there")
        general.solvers[key] = assemble(form, general.options, loop=general.loop,
                                        system=general.system)
    return general.solvers[key]


def _missing(ocp: Ocp, names: tuple[str, ...]) -> str | None:
    """Why the OCP cannot hold a solution of the parts ``names`` (one it has not), or None."""
    ours = [str(n) for n in parts_record(ocp)["parts"]]
    missing = [n for n in names if n not in ours]
    if not missing:
        return None
    return (f"the stored initial guess holds the part{'s' * (len(missing) > 1)} "
            f"{', '.join(missing)} this OCP has not (its parts: {', '.join(ours)}); not used")


def _other_variables(ref: Ocp, stored: dict[str, np.ndarray]) -> str | None:
    """Why the file's record (``stored``, :func:`parts_record`) is not that of ``ref``'s
    parts (the OCP's parts of the file's names), or None."""
    ocp_record, file_parts = parts_record(ref), [str(n) for n in stored["parts"]]
    if ocp_record["parts"].tolist() != file_parts:
        return (f"the stored initial guess has its parts in another order "
                f"({', '.join(file_parts)}) than this OCP "
                f"({', '.join(ocp_record['parts'].tolist())})")
    ours, theirs = ocp_record["part_variables"].tolist(), stored["part_variables"].tolist()
    if ours == theirs:
        return None
    other = sorted({v.split()[0] for v in set(ours) ^ set(theirs)}) or file_parts
    return (f"the stored initial guess has other variables of the part"
            f"{'s' * (len(other) > 1)} {', '.join(other)} than this OCP")


def load(ocp: Ocp, path: str | Path = GUESS_PATH) -> tuple[Solution | None, str]:
    """The stored solution if it fits ``ocp``, else ``None``; and why (for the log).

    The file holds a solution of the general (IPOPT) layout of the parts it records
    (:func:`parts_record`). It is checked on ``ocp``'s parts of those names
    (:func:`reference`: each of them there, with the recorded variables) and carried
    over to ``ocp`` (:func:`optimize.solve.result.carry_over`): to another layout
    (fatrop's stage-wise one), and to more parts, which fill their own variables along it
    (the winding temperature: its cyclic steady temperature).

    Parameters
    ----------
    ocp : Ocp
        The OCP to start.
    path : str or Path
        The guess file.

    Returns
    -------
    solution : Solution or None
    reason : str
        What was checked, or why the file does not fit.
    """
    data, why = _read(path)
    if data is None:  # missing, unreadable, edited or damaged: said, once
        return None, _warn(why)
    names = tuple(str(n) for n in data["parts"])
    why = _missing(ocp, names)
    ref = reference(ocp, names) if why is None else ocp
    why = why or _other_variables(ref, data)
    if why is not None:
        return None, why
    stored_mesh = on_mesh(ref, int(data["n_intervals"]), int(data["degree"]))
    solution, why = _check(stored_mesh, data)
    if solution is None:  # another system's is no surprise; an intact file unfit is stale
        return None, why if why.startswith(OTHER_SYSTEM) else _warn(f"{path}: {why}")
    if stored_mesh is not ref:
        solution = interpolated(stored_mesh, solution, ref)
        why = (f"{why}; interpolated from N={stored_mesh.n_intervals}, degree "
               f"{stored_mesh.coll.degree} onto N={ref.n_intervals}, degree {ref.coll.degree}")
    if ref is ocp:
        return solution, why
    return (carry_over(ref, solution, ocp, recorded_scenario(data).parameters),
            f"{why}; carried over to this OCP's {ocp.layout.name} layout and parts")


def recorded_scenario(data: dict) -> Scenario:
    """The scenario a start file holds the solution of (its ``scenario`` name, e.g.
    ``"elec-lim-7.0"``)."""
    kind, wind = str(data["scenario"]).rsplit("-", 1)
    return Scenario.of_kind(kind, float(wind))


def check_start_file(path: str | Path, system_sha256: str) -> None:
    """Refuse a start file (``--start``) that cannot be read, is damaged, or holds the
    solution of another system than the one of hash ``system_sha256``.

    Raises
    ------
    InputError
        Naming the file and why.
    """
    data, why = _read(path)
    if data is None:
        raise InputError(path, why, expected="a start file bench optimize wrote (start.npz)")
    if data["system_sha256"] != system_sha256:
        stored = data["system_sha256"][:12] or "not recorded"
        raise InputError(path, f"{OTHER_SYSTEM} (sha256 {stored}); the sweep's system has "
                         f"{system_sha256[:12]}",
                         expected="the start file of a sweep of this very system file")


def checked_options(options: OcpOptions) -> OcpOptions:
    """``options`` with the stored guess switched off when the file it would start from
    (``--start``'s, or the shipped one) is missing, unreadable, edited or damaged: said
    here, once per run, as a warning (:func:`load` would say it again in every worker
    process that starts a chain); the solves then start as with ``--no-stored-guess``.
    An intact file that does not fit an OCP is found by :func:`load`, per OCP."""
    o = options.solver
    if not o.stored_guess:
        return options
    data, why = _read(o.start_file or GUESS_PATH)
    if data is not None:
        return options
    _warn(why)
    return dataclasses.replace(options, solver=dataclasses.replace(o, stored_guess=False))


def _warn(why: str) -> str:
    """Say (once per run, as a warning) why the stored initial guess is not used, before
    the cold start falls back to the homotopy; return ``why``. A file that cannot be
    used at all is said in the command's own process (:func:`checked_options`); one that
    does not fit the OCP is found where the OCP is, in every worker process that starts
    a chain, and said by the first of them only (:func:`_first_in_run`)."""
    if why not in _SAID:
        _SAID.add(why)
        if _first_in_run(why):
            log.warning("stored initial guess not used: %s; the cold start runs the homotopy",
                        why)
    return why


def _first_in_run(why: str) -> bool:
    """Whether no other process of this run has said ``why``: the command and the local
    worker processes it starts share a process group, and the first of them to say a
    reason holds a name for it (a Linux abstract socket of the group and the reason,
    gone with the process) for as long as it lives. Where there are no such names, or
    for a Dask worker (a group of its own, its own log), each process says it."""
    digest = hashlib.sha256(f"{os.getpgid(0)} {why}".encode()).hexdigest()[:40]
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    try:
        sock.bind(f"\0drivebench-stored-guess-{digest}")
    except OSError as exc:
        sock.close()
        return exc.errno != errno.EADDRINUSE
    _HELD.append(sock)
    return True


def interpolated(src: Ocp, solution: Solution, dst: Ocp) -> Solution:
    """``solution`` of ``src`` on ``dst``'s mesh: the primal point and the bound
    multipliers interpolated in time (:mod:`optimize.solve.starts.remesh`), the constraint
    multipliers zero (as the mesh check starts a finer mesh)."""
    return Solution(w=interpolate_solution(src, solution, dst),
                    lam_x=interpolate_multipliers(src, solution, dst),
                    lam_g=np.zeros(dst.layout.n_g), n_intervals=dst.n_intervals,
                    degree=dst.coll.degree)


def _read(path: str | Path) -> tuple[dict | None, str]:
    """The file's arrays and scalars by name, or None and why."""
    path = Path(path)
    if not path.is_file():
        return None, f"no stored initial guess at {path}"
    try:
        with np.load(path) as f:
            stored = {k: f[k] for k in f.files}
        data = {k: stored[k] for k in (*ARRAYS, "n_intervals", "degree", "scenario")}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        return None, (f"cannot read the stored initial guess {path} ({type(exc).__name__}: "
                      f"{exc}): restore the shipped file or regenerate it ({REGENERATE})")
    data["system_sha256"] = str(stored.get("system_sha256", ""))
    record = {k: stored[k] for k in ("parts", "part_variables") if k in stored}
    if len(record) < 2:
        return None, (f"the stored initial guess {path} does not record its parts (written "
                      f"before it did): {REGENERATE} --record-parts kite,drive adds the record")
    if HASH_KEY not in stored:
        return None, (f"the stored initial guess {path} records no content hash (written "
                      f"before it did): {REGENERATE} --record-parts kite,drive checks it and "
                      "adds it")
    if str(stored[HASH_KEY]) != content_sha256(stored):
        return None, (f"the stored initial guess {path} differs from the SHA-256 it records "
                      f"(edited or damaged): restore the shipped file or regenerate it "
                      f"({REGENERATE})")
    return {**data, **record}, ""


def _check(ocp: Ocp, data: dict) -> tuple[Solution | None, str]:
    """:func:`load` on the OCP of the file's own layout and parts."""
    stored_system = data["system_sha256"]
    system = getattr(ocp.system, "sha256", None)
    if system is not None and system != stored_system:
        return None, (f"{OTHER_SYSTEM} (sha256 "
                      f"{stored_system[:12] or 'not recorded'}); this OCP's system "
                      f"{ocp.system.name} has {system[:12]}")
    n, d = int(data["n_intervals"]), int(data["degree"])
    if (n, d) != (ocp.n_intervals, ocp.coll.degree):
        return None, (f"the stored initial guess is for N={n}, degree {d}; this OCP has "
                      f"N={ocp.n_intervals}, degree {ocp.coll.degree}")
    lay = ocp.layout
    # an RMS torque row ([drive] continuous_torque_nm) is appended after the guess's rows
    n_rms = lay.rows_of("rms_torque").size
    n_g = lay.n_g - n_rms
    if (data["w"].size, data["g"].size, data["p"].size) != (lay.n_w, n_g, lay.n_p):
        return None, "the stored initial guess has another variable or constraint layout"
    g_now = ocp.constraint_values(data["w"], data["p"])[:n_g]
    dev = float(np.max(np.abs(g_now - data["g"])))
    if not dev <= MATCH_TOL:
        return None, (f"the stored initial guess does not fit this OCP's constraints (largest "
                      f"deviation {dev:.1e}): it was solved with another drive model or "
                      "rating than this OCP's (a sizing candidate, a fitted or carried "
                      "model: expected, the homotopy starts it), or the system's equations "
                      "changed since it was written (then regenerate it: "
                      "python -m optimize.solve.starts.stored_guess)")
    lam_g = np.concatenate([data["lam_g"], np.zeros(n_rms)])
    solution = Solution(w=data["w"], lam_x=data["lam_x"], lam_g=lam_g, n_intervals=n,
                        degree=d, p=data["p"],
                        drive_limits=recorded_scenario(data).drive_limits)
    return solution, f"stored initial guess {data['scenario']} fits (deviation {dev:.1e})"


def record_parts(path: str | Path, ocp: Ocp, names: tuple[str, ...]) -> tuple[bool, str]:
    """Add the record of ``ocp``'s parts ``names`` (:func:`parts_record`) and the content
    hash (:data:`HASH_KEY`) to a guess file written before the files recorded them, once
    the file fits the OCP of those parts (:func:`reference`); its arrays are kept as they
    are. Whether it was written, and what was checked or why not (the file untouched)."""
    try:
        with np.load(path) as f:
            old = {k: f[k] for k in f.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        return False, f"cannot read the stored initial guess {path}: {exc}"
    if HASH_KEY in old and str(old[HASH_KEY]) != content_sha256(old):
        return False, ("it differs from the SHA-256 it records (edited or damaged): "
                       f"restore it or regenerate it ({REGENERATE})")
    why = _missing(ocp, names)
    if why is not None:
        return False, why
    try:
        ref = reference(ocp, names)
        data = {**old, "system_sha256": str(old.get("system_sha256", ""))}
        solution, why = _check(ref, data)
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        said = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
        return False, (f"the parts {', '.join(names)} make no OCP to check the file on "
                       f"({said}); name every part it was written with (the shipped file: "
                       "kite,drive)")
    if solution is None:
        return False, why
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        _save(fh, {**old, **parts_record(ref)})
    return True, why


def _part_names(spec: str, ocp: Ocp) -> tuple[str, ...]:
    """The parts ``--record-parts`` names, each one of ``ocp``'s, once."""
    names = tuple(n.strip() for n in spec.split(","))
    ours = [str(n) for n in parts_record(ocp)["parts"]]
    if not spec.strip() or any(not n for n in names):
        raise InputError(None, f"--record-parts {spec!r}: names no part (or an empty one)",
                         expected="the parts the file holds, comma-separated, of "
                                  + ", ".join(ours))
    unknown = [n for n in names if n not in ours]
    if unknown or len(set(names)) != len(names):
        problem = (f"unknown part{'s' * (len(unknown) > 1)} {', '.join(unknown)}" if unknown
                   else "a part named twice")
        raise InputError(None, f"--record-parts {spec!r}: {problem}",
                         expected=f"each once, of the OCP's parts {', '.join(ours)}")
    return names


def main(argv: list[str] | None = None) -> int:
    """Solve :data:`GUESS_SCENARIO` by the homotopy and write the guess file (or, with
    ``--record-parts``, add the parts record and content hash to a file written before
    it had them). Exit 0 when written, 1 when the homotopy failed, 2 on bad input (the
    file untouched)."""
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--out", type=Path, default=GUESS_PATH)
    ap.add_argument("--record-parts", metavar="NAMES",
                    help="comma-separated parts the file at --out holds (kite,drive): "
                         "check it on their OCP and add their record, solving nothing")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    system, model = load_system(), paper_model()
    drive, _ = drive_in_force(system, drive_model=model)
    ocp = build_ocp(kite_dae(*system.model_params()), model, OcpOptions(),
                    system=system.in_force(drive))
    try:
        if args.record_parts is not None:
            names = _part_names(args.record_parts, ocp)
            if not args.out.is_file():
                raise InputError(args.out, "no guess file to record the parts of",
                                 column="--out", expected="an existing .npz guess file")
            done, why = record_parts(args.out, ocp, names)
            if not done:
                raise InputError(args.out, f"not changed: {why}")
            log.info("%s: %s", args.out, why)
            return 0
        check_output_file(args.out)  # before the solve, not after it
    except InputError as exc:
        print(f"stored_guess: error: {exc.describe()}", file=sys.stderr)
        return 2
    result = solve_by_homotopy(ocp, GUESS_SCENARIO)
    if not result.success:
        log.error("%s: %s, no guess written", GUESS_SCENARIO.name, result.status)
        return 1
    p = ocp.params(GUESS_SCENARIO.parameters, GUESS_SCENARIO.weights)
    out = write(args.out, ocp, result, p)
    log.info("wrote %s (%s: P_elec %.1f W, P_mech %.1f W, %d iterations)", out,
             GUESS_SCENARIO.name, result.avg_p_elec_w, result.avg_p_mech_w, result.iterations)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
