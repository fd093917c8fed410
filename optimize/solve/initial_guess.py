"""A shipped solution to start a chain from, in place of the homotopy.

``optimize/data/initial_guess.npz`` holds the scaled primal and dual solution of
one scenario (:data:`GUESS_SCENARIO`, elec-lim-7.0, solved by the homotopy with
the paper's Table I drive model, the shipped ``highwind.toml`` system, at the default
discretization), the NLP parameters it was solved with, the scaled constraint values
``g(w, p)`` there and the system's hash.

:func:`load` accepts the file for an OCP only if the OCP's system (when it has
one) is the stored one and it evaluates the same ``g`` at the stored point to
:data:`MATCH_TOL`. The constraints do not depend on
the drive model, so the guess serves any fitted model; a changed kite model,
scaling, collocation or layout makes it stale, and :func:`optimize.solve.solve.start`
falls back to the homotopy. Regenerate the file with::

    .venv/bin/python -m optimize.solve.initial_guess
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
from optimize.problem.ocp import Ocp, assemble, build_ocp, twin
from optimize.problem.options import OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.homotopy import cold_start
from optimize.solve.result import OcpResult, Solution, carry_over
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

log = logging.getLogger(__name__)

#: the shipped file
GUESS_PATH = Path(__file__).resolve().parent.parent / "data" / "initial_guess.npz"
#: the scenario it holds: its solution warm-starts both objectives at 7 m/s
GUESS_SCENARIO = Scenario(wind_speed_m_s=7.0, objective="electrical", drive_limits=True)
#: largest deviation of the scaled constraint values at the stored point [-]
MATCH_TOL = 1e-9
#: the parts of the OCP the file holds a solution of (:mod:`optimize.problem.parts`)
STORED_PARTS = ("kite", "drive")
#: the arrays of the file besides its scalars
ARRAYS = ("w", "lam_x", "lam_g", "p", "g")


def write(path: str | Path, ocp: Ocp, result: OcpResult, p: np.ndarray) -> Path:
    """Store ``result``'s solution with its parameters ``p`` and ``g(w, p)`` (atomic)."""
    w = result.warm.w
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        np.savez_compressed(
            fh, w=w, lam_x=result.warm.lam_x, lam_g=result.warm.lam_g, p=p,
            g=ocp.constraint_values(w, p), n_intervals=ocp.n_intervals,
            degree=ocp.coll.degree, scenario=result.scenario.name,
            system_sha256=getattr(ocp.system, "sha256", ""),
        )
    return Path(path)


def reference(ocp: Ocp) -> Ocp:
    """The OCP the stored file is checked against: ``ocp`` in the general (IPOPT)
    layout with only the parts the file was made with (:data:`STORED_PARTS`); ``ocp``
    itself when it is that (built once, cached on ``ocp``)."""
    general = twin(ocp, "ipopt")
    parts = getattr(general.formulation, "parts", ())
    kept = tuple(p for p in parts if p.name in STORED_PARTS)
    if len(kept) == len(parts):
        return general
    key = ("stored parts",)
    if key not in general.solvers:
        form = dataclasses.replace(general.formulation, parts=kept)
        general.solvers[key] = assemble(form, general.options, loop=general.loop,
                                        system=general.system)
    return general.solvers[key]


def load(ocp: Ocp, path: str | Path = GUESS_PATH) -> tuple[Solution | None, str]:
    """The stored solution if it fits ``ocp``, else ``None``; and why (for the log).

    The file holds a solution of the general (IPOPT) layout of the kite's parts
    (:data:`STORED_PARTS`). It is checked on that problem (:func:`reference`) and
    carried over to ``ocp`` (:func:`optimize.solve.result.carry_over`): to another
    layout (fatrop's stage-wise one), and to more parts, which fill their own variables
    along it (the winding temperature: its cyclic steady temperature).

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
    ref = reference(ocp)
    if ref is not ocp:
        solution, why = _check(ref, path)
        if solution is None:
            return None, why
        return (carry_over(ref, solution, ocp, GUESS_SCENARIO.parameters),
                f"{why}; carried over to this OCP's {ocp.layout.kind} layout and parts")
    return _check(ocp, path)


def _check(ocp: Ocp, path: str | Path) -> tuple[Solution | None, str]:
    """:func:`load` on the OCP of the file's own layout and parts."""
    path = Path(path)
    if not path.is_file():
        return None, f"no stored initial guess at {path}"
    try:
        with np.load(path) as f:
            data = {k: f[k] for k in (*ARRAYS, "n_intervals", "degree", "scenario")}
            stored_system = str(f["system_sha256"]) if "system_sha256" in f.files else ""
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        return None, f"cannot read the stored initial guess {path}: {exc}"
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
                      "python -m optimize.solve.initial_guess")
    lam_g = np.concatenate([data["lam_g"], np.zeros(n_rms)])
    solution = Solution(w=data["w"], lam_x=data["lam_x"], lam_g=lam_g,
                        n_intervals=n, degree=d)
    return solution, f"stored initial guess {data['scenario']} fits (deviation {dev:.1e})"


def main(argv: list[str] | None = None) -> int:
    """Solve :data:`GUESS_SCENARIO` by the homotopy and write the guess file."""
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--out", type=Path, default=GUESS_PATH)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    system, model = load_system(), paper_model()
    rating = drive_in_force(system, model=model).rating
    ocp = build_ocp(kite_dae(*system.model_params()), model,
                    system.ocp_options(OcpOptions(), rating), system=system)
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
