"""The sweep's trust checks with a verdict each: mesh refinement and the independent
simulation of the optimal controls (``trust`` of the optimize manifest, docs/schemas.md §5).

The verdict rules, stated in the report beside the tables:

* mesh: the optimum moves by at most :data:`MESH_SHARE` of the cycle's mechanical power
  when the intervals double (the electrical power can be near zero, so it is measured
  against the power flowing through the drive, not against itself);
* simulation: the collocation states match an independent integration of the dynamics
  from each interval's start within :data:`DEFECT_M` (the discretization's error); the
  whole cycle integrated open loop from its initial state, without the optimizer's
  corrections, drifts by more than :data:`OPEN_LOOP_M` only when the cycle is unstable
  in open loop, which the discretization check tells apart from an error.
"""

from __future__ import annotations

import pandas as pd

from reports.tables import fmt, frame_table

#: mesh check: largest change of the average electrical power, as a share of |P_mech|
MESH_SHARE = 0.01
#: simulation check: largest position defect over one collocation interval [m]
DEFECT_M = 0.01
#: simulation check: largest open-loop drift over the cycle before it is called unstable [m]
OPEN_LOOP_M = 1.0


def mesh_verdict(r: dict) -> str:
    """The verdict of one mesh-check record (see the module)."""
    if not r.get("success"):
        return f"fine-mesh solve failed ({r.get('status')})"
    change = abs(float(r["avg_p_elec_fine_w"]) - float(r["avg_p_elec_w"]))
    scale = max(abs(float(r["avg_p_mech_w"])), 1e-9)
    if change <= MESH_SHARE * scale:
        return f"converged (P_elec moves {fmt(100 * change / scale, 2)} % of |P_mech|)"
    return f"NOT converged: P_elec moves {fmt(100 * change / scale, 2)} % of |P_mech|"


def simulation_verdict(r: dict) -> str:
    """The verdict of one simulation-check record (see the module); a simulation that could
    not finish (no figures, its record's own ``verdict`` says why) fails."""
    if r.get("interval_defect_position_m") is None or r.get("open_loop_position_m") is None:
        why = str(r.get("verdict") or "the simulation recorded no figures")
        return f"FAILS: {why.removeprefix('failed: ')}"
    defect, drift = float(r["interval_defect_position_m"]), float(r["open_loop_position_m"])
    if defect > DEFECT_M:
        return f"FAILS: defect {fmt(defect, 3)} m over one interval"
    if drift <= OPEN_LOOP_M:
        return "passes; closes in open loop"
    return ("passes; unstable in open loop (the drift is the dynamics', not the "
            "discretization's)")


def trust_checks(manifest: dict) -> dict:
    """The trust checks as tables with verdicts.

    Returns
    -------
    dict
        ``mesh`` and ``simulation``: ``{"table", "failed", "integrator"}`` or None when
        not run; ``table`` has a ``verdict`` column; ``failed`` counts the rows whose
        verdict is not a pass, ``unstable`` those unstable in open loop; ``integrator``
        is said once, not per row; ``rules`` the thresholds, for the text.
    """
    trust = manifest.get("trust") if isinstance(manifest.get("trust"), dict) else {}
    out: dict = {"mesh": None, "simulation": None,
                 "rules": {"mesh_pct": fmt(100 * MESH_SHARE, 2), "defect_m": fmt(DEFECT_M),
                           "open_loop_m": fmt(OPEN_LOOP_M)}}
    for name, verdict, columns in (
            ("mesh", mesh_verdict, ("scenario", "n_intervals", "n_intervals_fine", "status",
                                    "avg_p_elec_w", "avg_p_elec_fine_w", "avg_p_mech_w",
                                    "period_s", "period_fine_s")),
            ("simulation", simulation_verdict, ("scenario", "interval_defect_position_m",
                                                "open_loop_position_m",
                                                "periodicity_error_position_m"))):
        records = [r for r in trust.get(name) or [] if isinstance(r, dict)]
        if not records:
            continue
        frame = pd.DataFrame(records)
        frame = frame[[c for c in columns if c in frame.columns]].assign(
            verdict=[verdict(r) for r in records])
        integrators = {str(r.get("integrator")) for r in records if r.get("integrator")}
        out[name] = {"table": frame_table(frame),
                     "failed": sum(not v.startswith(("converged", "passes"))
                                   for v in frame["verdict"]),
                     "unstable": sum("unstable" in v for v in frame["verdict"]),
                     "integrator": "; ".join(sorted(integrators))}
    return out
