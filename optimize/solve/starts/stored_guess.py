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
(saying why). Regenerate the file with::

    .venv/bin/python -m optimize.solve.starts.stored_guess

A file written before it recorded its parts gets the record, checked on the OCP of the
parts named, with ``--record-parts kite,drive`` (its arrays unchanged).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import zipfile
from pathlib import Path

import numpy as np

from kernel.files import atomic_path
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import Ocp, assemble, build_ocp, on_mesh, twin
from optimize.problem.options import OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.result import OcpResult, Solution, carry_over
from optimize.solve.starts.fill import KEYS
from optimize.solve.starts.homotopy import cold_start
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
    """Store ``result``'s solution with its parameters ``p``, ``g(w, p)`` and the parts
    of ``ocp`` (:func:`parts_record`; atomic)."""
    warm = result.warm
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        np.savez_compressed(
            fh, w=warm.w, lam_x=warm.lam_x, lam_g=warm.lam_g, p=p,
            g=ocp.constraint_values(warm.w, p), n_intervals=ocp.n_intervals,
            degree=ocp.coll.degree, scenario=result.scenario.name,
            system_sha256=getattr(ocp.system, "sha256", ""), **parts_record(ocp),
        )
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
    if data is None:
        return None, why
    names = tuple(str(n) for n in data["parts"])
    why = _missing(ocp, names)
    ref = reference(ocp, names) if why is None else ocp
    why = why or _other_variables(ref, data)
    if why is not None:
        return None, why
    stored_mesh = on_mesh(ref, int(data["n_intervals"]), int(data["degree"]))
    solution, why = _check(stored_mesh, data)
    if solution is None:
        return None, why
    if stored_mesh is not ref:
        solution = interpolated(stored_mesh, solution, ref)
        why = (f"{why}; interpolated from N={stored_mesh.n_intervals}, degree "
               f"{stored_mesh.coll.degree} onto N={ref.n_intervals}, degree {ref.coll.degree}")
    if ref is ocp:
        return solution, why
    return (carry_over(ref, solution, ocp, GUESS_SCENARIO.parameters),
            f"{why}; carried over to this OCP's {ocp.layout.kind} layout and parts")


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
            data = {k: f[k] for k in (*ARRAYS, "n_intervals", "degree", "scenario")}
            data["system_sha256"] = str(f["system_sha256"]) if "system_sha256" in f.files else ""
            record = {k: f[k] for k in ("parts", "part_variables") if k in f.files}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        return None, f"cannot read the stored initial guess {path}: {exc}"
    if len(record) < 2:
        return None, (f"the stored initial guess {path} does not record its parts (written "
                      "before it did): python -m optimize.solve.starts.stored_guess --record-parts "
                      "kite,drive adds the record")
    return {**data, **record}, ""


def _check(ocp: Ocp, data: dict) -> tuple[Solution | None, str]:
    """:func:`load` on the OCP of the file's own layout and parts."""
    stored_system = data["system_sha256"]
    system = getattr(ocp.system, "sha256", None)
    if system is not None and system != stored_system:
        return None, (f"the stored initial guess is for another system (sha256 "
                      f"{stored_system[:12] or 'not recorded'}); this OCP's system "
                      f"{ocp.system.name} has {system[:12]}")
    n, d = int(data["n_intervals"]), int(data["degree"])
    if (n, d) != (ocp.n_intervals, ocp.coll.degree):
        return None, (f"the stored initial guess is for N={n}, degree {d}; this OCP has "
                      f"N={ocp.n_intervals}, degree {ocp.coll.degree}")
    lay = ocp.layout
    # an RMS torque row (Limits.max_rms_torque_nm) is appended after the guess's rows
    n_rms = lay.rows_of("rms_torque").size
    n_g = lay.n_g - n_rms
    if (data["w"].size, data["g"].size, data["p"].size) != (lay.n_w, n_g, lay.n_p):
        return None, "the stored initial guess has another variable or constraint layout"
    g_now = ocp.constraint_values(data["w"], data["p"])[:n_g]
    dev = float(np.max(np.abs(g_now - data["g"])))
    if not dev <= MATCH_TOL:
        return None, (f"the stored initial guess does not fit this OCP's constraints (largest "
                      f"deviation {dev:.1e}); regenerate it: "
                      "python -m optimize.solve.starts.stored_guess")
    lam_g = np.concatenate([data["lam_g"], np.zeros(n_rms)])
    solution = Solution(w=data["w"], lam_x=data["lam_x"], lam_g=lam_g,
                        n_intervals=n, degree=d)
    return solution, f"stored initial guess {data['scenario']} fits (deviation {dev:.1e})"


def record_parts(path: str | Path, ocp: Ocp, names: tuple[str, ...]) -> tuple[bool, str]:
    """Add the record of ``ocp``'s parts ``names`` (:func:`parts_record`) to a guess file
    written before the files recorded their parts, once the file fits the OCP of those
    parts (:func:`reference`); its arrays are kept as they are. Whether it was written,
    and what was checked or why not."""
    try:
        with np.load(path) as f:
            old = {k: f[k] for k in f.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        return False, f"cannot read the stored initial guess {path}: {exc}"
    why = _missing(ocp, names)
    if why is not None:
        return False, why
    ref = reference(ocp, names)
    data = {**old, "system_sha256": str(old.get("system_sha256", ""))}
    solution, why = _check(ref, data)
    if solution is None:
        return False, why
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        np.savez_compressed(fh, **{**old, **parts_record(ref)})
    return True, why


def main(argv: list[str] | None = None) -> int:
    """Solve :data:`GUESS_SCENARIO` by the homotopy and write the guess file (or, with
    ``--record-parts``, add the parts record to the file written before it had one)."""
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--out", type=Path, default=GUESS_PATH)
    ap.add_argument("--record-parts", metavar="NAMES",
                    help="comma-separated parts the file at --out holds (kite,drive): "
                         "check it on their OCP and add their record, solving nothing")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    system, model = load_system(), paper_model()
    rating = drive_in_force(system, drive_model=model).rating
    ocp = build_ocp(kite_dae(*system.model_params()), model,
                    system.ocp_options(OcpOptions(), rating), system=system)
    if args.record_parts:
        done, why = record_parts(args.out, ocp, tuple(args.record_parts.split(",")))
        (log.info if done else log.error)("%s: %s", args.out, why)
        return 0 if done else 1
    result = cold_start(ocp, GUESS_SCENARIO)
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
