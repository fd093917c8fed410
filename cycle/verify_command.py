"""``bench cycle verify`` as a library call: read the store and the sweep, compare, write
the output folder (docs/schemas.md §11, :mod:`cycle.verify_folder`) whole."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest.cycles import CLOCK_RTOL
from bench.store.manifest import read_manifest
from bench.store.read import read_cycles, read_samples
from cycle.models import sweep_power_model
from cycle.provenance import check_provenance
from cycle.verify import (
    CLAIM_RTOL,
    Accuracy,
    K,
    energy_drift,
    generated_words,
    measured_energy,
    model_energy,
    round_trip_result,
)
from cycle.verify_folder import MARKERS, STAGE, write_verify_folder
from kernel.errors import InputError
from kernel.output_folder import check_replaceable
from kernel.provenance import Provenance
from optimize.sweep_folder import read_sweep_folder, read_trajectories


def cycle_session(store: Path, session: str | None) -> tuple[str, dict]:
    """The cycle-run session to verify (``session``, or the store's only one) and its
    manifest entry."""
    if not (store / "manifest.json").is_file():
        raise InputError(store, "no store here (no manifest.json)" if store.is_dir() else
                         "not found", column="--store",
                         expected="the store bench ingest wrote the cycle run into")
    manifest = read_manifest(store)
    runs = {sid: e for sid, e in manifest["sessions"].items()
            if isinstance(e, dict) and e.get("kind") == "cycle_run"}
    if session is None and len(runs) == 1:
        session = next(iter(runs))
    if session not in runs:
        raise InputError(store / "manifest.json",
                         f"no cycle-run session {session!r}" if session else
                         f"{len(runs)} cycle-run sessions, none chosen", column="--session",
                         expected="one of: " + (", ".join(sorted(runs)) or "none stored "
                                                "(bench ingest a session of kind = cycle_run)"))
    entry = runs[session]
    if not (entry.get("cycles") or {}).get("n_kept"):
        raise InputError(store / "manifest.json", f"session {session!r} kept no cycle: "
                         + "; ".join((entry.get("cycles") or {}).get("notes", [])),
                         column="--session", expected="a cycle run with kept cycles")
    return session, entry


def period_uncertainty(info: dict) -> float:
    """The standard uncertainty of the period a session's cycles were cut with [s]: the
    fit's when the period found was used, else the clocks' tolerance on the profile's."""
    if info["period_s"] != info["period_profile_s"] and info.get("period_found_u_s"):
        return float(info["period_found_u_s"])
    return CLOCK_RTOL * float(info["period_profile_s"])


def _means(table: pd.DataFrame, e_opt: float) -> dict:
    """Means over the kept cycles, their standard uncertainties and relative errors."""
    n = len(table)
    e = float(table["e_elec_j"].mean())
    u_sys = float(table["u_elec_systematic_j"].mean())  # common to every cycle
    u_rand = float(math.sqrt((table["u_elec_random_j"] ** 2).mean() / n))
    u_meas = math.hypot(u_sys, u_rand)
    u_model = float(table["u_model_j"].mean())
    e_model = float(table["e_elec_model_j"].mean())
    m = float(table["e_mech_j"].mean())
    u_m = math.hypot(float(table["u_mech_systematic_j"].mean()),
                     float(table["u_mech_random_j"].mean()) / math.sqrt(n))
    return {"n_cycles": n, "e_elec_j": e, "u_elec_j": u_meas, "band_elec_j": K * u_meas,
            "e_elec_model_j": e_model, "u_model_j": u_model, "e_elec_optimizer_j": e_opt,
            "e_mech_j": m, "u_mech_j": u_m, "band_mech_j": K * u_m,
            "model_error": (e_model - e) / abs(e),
            "model_error_band": K * math.hypot(u_meas, u_model) / abs(e),
            "optimizer_error": (e_opt - e) / abs(e),
            "optimizer_error_band": K * u_meas / abs(e)}


def residual_std_w(model) -> float | None:
    """The power model's residual standard deviation at its own steady points [W]
    (``statistics.residuals.all.std_w`` of ``bench fit``; None when the model has none)."""
    try:
        value = float(model.statistics["residuals"]["all"]["std_w"])
    except (TypeError, KeyError, ValueError):
        return None
    return value if math.isfinite(value) else None


def verdict(means: dict, drift: dict, missing: list[str],
            residual: tuple[float, float] | None = None) -> str:
    """The result in plain words, PASS, FAIL or INCONCLUSIVE against :data:`CLAIM_RTOL`
    first (:func:`cycle.verify.round_trip_result`), every energy said as generated (or
    drawn) per cycle and every error as the prediction against the measurement of that
    energy; ``residual`` is the model's residual std at its steady points [W] and a
    cycle's period [s], when the model states it."""
    err, band = means["model_error"], means["model_error_band"]
    word, measured = generated_words(means["e_elec_j"])
    sign = -1.0 if word == "generated" else 1.0  # every energy in the measured one's sense
    model = sign * means.get("e_elec_model_j", means["e_elec_j"] * (1 + err))
    promised = sign * means["e_elec_optimizer_j"]
    where = "delivered to" if word == "generated" else "taken from"
    lines = [f"{round_trip_result(err, band)} against +-{100 * CLAIM_RTOL:g} % (the steady "
             "map's accuracy on dynamic cycles the paper states): the steady-state power "
             f"model at the measured speed and torque predicts {model:.0f} J {word} per cycle "
             f"against {measured:.0f} J measured, {_off(err, word)} (95 % band "
             f"+-{100 * band:.1f} %).",
             f"The optimizer promised {promised:.0f} J {word}, "
             f"{_off(means['optimizer_error'], word)} (band "
             f"+-{100 * means['optimizer_error_band']:.1f} %).",
             f"Energies are per cycle, {word} ({where} the grid); an error is the prediction "
             "against the measurement of that energy."]
    if math.isfinite(drift["slope_j_per_cycle"]) and abs(drift["slope_j_per_cycle"]) > \
            K * drift["slope_u_j_per_cycle"]:
        lines.append(f"The energy per cycle drifts by {drift['slope_j_per_cycle']:+.1f} J "
                     f"({100 * drift['slope_per_cycle']:+.2f} %) per cycle over "
                     f"{means['n_cycles']} cycles: the drive's temperature is moving.")
    else:
        lines.append("No drift over the cycles is resolved.")
    if residual is not None:
        std_w, period = residual
        lines.append(f"At its own steady points the map scatters by {std_w:.0f} W (residual "
                     f"std); held over a cycle of {period:.2f} s that is {std_w * period:.0f} J, "
                     f"{100 * std_w * period / abs(means['e_elec_j']):.1f} % of the energy "
                     "measured: the map promises no better on this cycle.")
    if missing:
        lines.append(f"session.toml [sensors] does not state {', '.join(missing)}: the band "
                     "leaves those instruments' limits of error out.")
    return " ".join(lines)


def _off(error: float, word: str) -> str:
    """A prediction's relative error ``(E_pred - E_meas) / |E_meas|`` as more or less of the
    energy ``word`` (generated: a negative error is more generated)."""
    more = error < 0 if word == "generated" else error > 0
    return f"{100 * abs(error):.1f} % {'more' if more else 'less'} than measured"


@dataclass(frozen=True)
class Verified:
    """What :func:`verify_cycles` found and wrote: ``folder``, ``record`` (verify.json),
    ``cycles`` (one row per kept cycle)."""

    folder: Path
    record: dict
    cycles: pd.DataFrame

    @property
    def verdict(self) -> str:
        """The verdict in words."""
        return self.record["verdict"]


def _one_cycle(samples: pd.DataFrame, row, model, traj: pd.DataFrame, phase_s: float,
               period_opt: float) -> pd.DataFrame:
    """Measured and predicted p_elec over one kept cycle, time from its start."""
    sel = (samples["time_s"] >= row.t_start_s) & (samples["time_s"] < row.t_end_s)
    s = samples[sel]
    t = s["time_s"].to_numpy(float) - row.t_start_s
    tp = np.mod(t * period_opt / row.period_s, period_opt)
    opt_t = np.concatenate([[0.0], traj["time_s"].to_numpy(float)])
    opt_p = np.concatenate([traj["p_elec_w"].to_numpy(float)[-1:], traj["p_elec_w"]])
    return pd.DataFrame({"time_s": t, "p_elec_measured_w": s["p_elec_w"].to_numpy(float),
                         "p_elec_model_w": model.p_elec_w(s["speed_rpm"], s["torque_nm"]),
                         "p_elec_optimizer_w": np.interp(tp, opt_t, opt_p),
                         "p_mech_measured_w": s["p_mech_w"].to_numpy(float)})


def verify_cycles(store: str | Path, optimize: str | Path, out: str | Path, *,
                  session: str | None = None, model=None,
                  command_line: Sequence[str] = ("drivebench.cycle_verify",)) -> Verified:
    """Compare a stored cycle run with the power model and the optimizer; write ``out``.

    Parameters
    ----------
    store : path
        The store holding the cycle-run session (``bench ingest``).
    optimize : path
        The optimize folder the profile was exported from.
    out : path
        The output folder (new, or an earlier ``bench cycle verify`` output).
    session : str, optional
        The session id (default the store's only cycle-run session).
    model : PowerModel, optional
        The power model to predict with (default the sweep's).
    command_line : sequence of str
        Recorded in the provenance header.
    """
    store, optimize = Path(store), Path(optimize)
    check_replaceable(out, STAGE, MARKERS)  # before the work
    provenance = Provenance.start(command_line)
    sid, entry = cycle_session(store, session)
    info = entry["cycles"]
    row, traj, model = _flown(optimize, info, sid, model)
    cycles = read_cycles(store)
    cycles = cycles[cycles["session_id"] == sid].sort_values("cycle_id")
    samples = read_samples(store, sid)
    acc, missing = Accuracy.of_session(entry.get("metadata") or {})
    table = measured_energy(cycles, acc, float((entry.get("timing") or {}).get("bin_s", 0.1)),
                            period_uncertainty(info))
    table["e_elec_model_j"], table["u_model_j"] = model_energy(cycles, samples, model)
    table["e_elec_optimizer_j"] = float(row["e_elec_j"])
    table["e_mech_optimizer_j"] = float(row["e_mech_j"])
    for col in ("t_start_s", "t_end_s", "period_s", "t_winding_c"):
        table[col] = cycles[col].to_numpy()
    table, cycles, dropped = _finite(table, cycles, sid, store)
    means = _means(table, float(row["e_elec_j"]))
    slope, slope_u, scatter = energy_drift(table["e_elec_j"].to_numpy(float),
                                     table["cycle_id"].to_numpy(float))
    drift = {"slope_j_per_cycle": slope, "slope_u_j_per_cycle": slope_u,
             "slope_per_cycle": slope / abs(means["e_elec_j"]), "scatter_j": scatter}
    mid = cycles.iloc[len(cycles) // 2]
    one = _one_cycle(samples, mid, model, traj[traj["scenario"] == info["scenario"]]
                     .sort_values("time_s"), info["phase_s"], float(row["period_s"]))
    residual = residual_std_w(model)
    record = {"store": str(store.resolve()),
              "session": sid, "scenario": info["scenario"], "optimize": str(optimize.resolve()),
              "optimize_run_id": info["provenance"]["optimize_run_id"],
              "trajectory_sha256": info["provenance"]["trajectory_sha256"],
              "power_model_sha256": model.sha256, "cycles_in_profile": info["n_profile_cycles"],
              "cycles_kept": len(cycles), "cycle_notes": [*info.get("notes", []), *dropped],
              "accuracy": acc.__dict__, "accuracy_missing": missing, "coverage_factor": K,
              "claim_rtol": CLAIM_RTOL, "means": means, "drift": drift,
              "result": round_trip_result(means["model_error"], means["model_error_band"]),
              "e_mech_optimizer_j": float(row["e_mech_j"]),
              "model_residual_std_w": residual, "one_cycle": int(mid.cycle_id),
              "verdict": verdict(means, drift, missing, None if residual is None
                                 else (residual, float(cycles["period_s"].mean())))}
    write_verify_folder(out, provenance, record, table, one)
    return Verified(Path(out), {"provenance": provenance.header(), **record}, table)


def _flown(optimize: Path, info: dict, sid: str, model) -> tuple[pd.Series, pd.DataFrame, object]:
    """The sweep's summary row of the scenario session ``sid`` flew, the sweep's
    trajectories and the power model (``model``, default the sweep's), once
    :func:`cycle.provenance.check_provenance` found the session flew this sweep's cycle."""
    summary, manifest = read_sweep_folder(optimize)
    row = summary[summary["scenario"] == info["scenario"]]
    if row.empty or not bool(row.iloc[0]["success"]):
        raise InputError(optimize / "summary.parquet", f"no converged scenario "
                         f"{info['scenario']!r}, which session {sid!r} flew",
                         column="--optimize", expected="the optimize folder the profile "
                         "was exported from")
    row = row.iloc[0]
    model = model if model is not None else sweep_power_model(optimize, manifest)
    traj = read_trajectories(optimize)
    check_provenance(info, sid, optimize, manifest, traj, float(row["e_mech_j"]), model.sha256)
    return row, traj, model


#: the columns of the verification table every figure is computed from
_FIGURES = ("e_elec_j", "u_elec_j", "e_mech_j", "u_mech_j", "e_elec_model_j", "u_model_j")


def _finite(table: pd.DataFrame, cycles: pd.DataFrame, sid: str,
            store: Path) -> tuple[pd.DataFrame, pd.DataFrame, list[str]]:
    """The cycles whose every figure is finite (every mean, band and the drift are over
    the same cycles), and one note per cycle left out (a store ingested before such
    cycles were rejected).

    Raises
    ------
    InputError
        No cycle is left.
    """
    ok = np.isfinite(table[list(_FIGURES)].to_numpy(float)).all(axis=1)
    notes = [f"cycle {int(r.cycle_id)}: left out, "
             + ", ".join(c for c in _FIGURES if not math.isfinite(getattr(r, c)))
             + " not finite (ingest the session again: it rejects such cycles)"
             for r in table[~ok].itertuples(index=False)]
    if not ok.any():
        raise InputError(store / "manifest.json", f"session {sid!r}: no kept cycle has "
                         "finite energies", column="--session",
                         expected="a cycle run with kept cycles (ingest it again)")
    return table[ok].reset_index(drop=True), cycles[ok], notes
