"""The report's section on the optimal cycle flown on the bench (``bench cycle verify``).

Reads ``verify_out/verify.json``, ``cycles.csv`` and ``one_cycle.csv`` (docs/schemas.md
§11) with their readers (:mod:`cycle.verify_folder`) through the
:class:`reports.inputs.InputLog`: predicted against measured power over
one cycle, the energy per cycle with its band, and the verdict. No folder: the stage was
not run, and the section says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from markupsafe import Markup

from cycle.verify_folder import (
    CYCLES_FILE,
    ONE_CYCLE_FILE,
    RECORD_FILE,
    read_cycles,
    read_one_cycle,
    read_record,
)
from reports import svg
from reports.inputs import InputLog
from reports.tables import fmt


def power_figure(one: pd.DataFrame, cycle_id: int) -> Markup:
    """Electrical power over one cycle: measured, the model at the measured speed and
    torque, the optimizer's; the measured shaft power for reference."""
    fig = svg.new_figure(7.0, 3.8)
    ax = fig.add_subplot()
    t = one["time_s"].astype(float)
    ax.plot(t, one["p_mech_measured_w"].astype(float), color="#999999", lw=1.0,
            label="shaft power, measured")
    ax.plot(t, one["p_elec_measured_w"].astype(float), color="#1f77b4", lw=1.4,
            label="electrical, measured")
    ax.plot(t, one["p_elec_model_w"].astype(float), color="#d62728", lw=1.0, ls="--",
            label="electrical, power model at the measured speed and torque")
    ax.plot(t, one["p_elec_optimizer_w"].astype(float), color="#2ca02c", lw=1.0, ls=":",
            label="electrical, the optimizer's cycle")
    ax.axhline(0.0, color="black", lw=0.5)
    ax.set_xlabel(f"time from the start of cycle {cycle_id} of the run [s]")
    ax.set_ylabel("power [W] (negative = generated)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return svg.to_svg(fig, "verification-power")


def energy_figure(cycles: pd.DataFrame, k: float) -> Markup:
    """Electrical energy per cycle: measured with its band, the model, the optimizer."""
    fig = svg.new_figure(6.4, 3.4)
    ax = fig.add_subplot()
    c = cycles["cycle_id"].astype(int)
    ax.errorbar(c, cycles["e_elec_j"], yerr=k * cycles["u_elec_j"], fmt="o", color="#1f77b4",
                capsize=3, label="measured (95 % band)")
    ax.plot(c, cycles["e_elec_model_j"], "s--", color="#d62728", ms=4,
            label="power model at the measured speed and torque")
    ax.plot(c, cycles["e_elec_optimizer_j"], ":", color="#2ca02c", label="optimizer")
    ax.set_xlabel("cycle")
    ax.set_ylabel("electrical energy per cycle [J]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return svg.to_svg(fig, "verification-energy")


def _pct(x) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:+.1f} %"


def _finite(*values) -> bool:
    return all(isinstance(v, int | float) and np.isfinite(v) for v in values)


def prediction_words(predicted_error: float | None, measured_j: float | None) -> str:
    """A prediction's error against a measured energy per cycle in words, unsigned:
    ``"17.7 % less energy generated than measured"``. ``predicted_error`` is
    ``(E_predicted - E_measured) / |E_measured|``; energies are positive when drawn from
    the grid, negative when generated (docs/schemas.md Conventions)."""
    if not _finite(predicted_error, measured_j):
        return "n/a"
    generated = measured_j < 0
    more = (predicted_error < 0) if generated else (predicted_error > 0)
    return (f"{100 * abs(predicted_error):.1f} % {'more' if more else 'less'} energy "
            f"{'generated' if generated else 'drawn'} than measured")


def _energy(value, sign: float, digits: int = 1) -> str:
    """An energy per cycle in the round trip's sense (``sign`` -1: generated positive)."""
    return fmt(None if value is None else sign * value, digits)


def round_trip_verdict(doc: dict) -> str | None:
    """The round trip's verdict in one line for Key results: PASS, FAIL or INCONCLUSIVE
    against :data:`cycle.verify.CLAIM_RTOL` (:func:`cycle.verify.round_trip_result`), then
    the power model's and the optimizer's energy per cycle against the measured one, all
    said as generated (or drawn) energy (None: no means)."""
    from cycle.verify import CLAIM_RTOL, generated_words, round_trip_result

    m = doc.get("means") or {}
    err, band = m.get("model_error"), m.get("model_error_band")
    if not _finite(err, band, m.get("e_elec_j")):
        return None
    result = doc.get("result") or round_trip_result(err, band)
    word, measured = generated_words(m["e_elec_j"])
    sign = -1.0 if word == "generated" else 1.0
    parts = [f"{result} against +-{100 * CLAIM_RTOL:g} %: the power model at the measured speed "
             f"and torque predicts {fmt(sign * m.get('e_elec_model_j'), 0)} J {word} per cycle "
             f"against {measured:.0f} J measured ({prediction_words(err, m['e_elec_j'])}, 95 % "
             f"band +-{100 * band:.1f} %; {doc.get('cycles_kept')} cycles of "
             f"{doc.get('scenario')})"]
    if _finite(m.get("e_elec_optimizer_j")):
        parts.append(f"the optimizer promised {sign * m['e_elec_optimizer_j']:.0f} J {word} "
                     f"({prediction_words(m.get('optimizer_error'), m['e_elec_j'])})")
    return "; ".join(parts)


def verification_section(log: InputLog, verify: Path) -> dict:
    """The section's context.

    Returns
    -------
    dict
        ``not_run``, ``missing``, ``record`` (verify.json, or None), ``rows`` (the means
        as (what, value) pairs), ``verdict``, ``headline`` (:func:`round_trip_verdict`),
        ``notes`` (the rejected cycles),
        ``power_figure``, ``energy_figure``.
    """
    start = len(log.missing)
    out = {"not_run": [], "missing": [], "record": None, "rows": [], "verdict": None,
           "headline": None,
           "notes": [], "power_figure": None, "energy_figure": None}
    if not Path(verify).is_dir():
        out["not_run"] = [f"bench cycle verify (no {verify})"]
        return out
    doc = log.read(verify, RECORD_FILE, read_record)
    cycles = log.read(verify, CYCLES_FILE, read_cycles)
    one = log.read(verify, ONE_CYCLE_FILE, read_one_cycle)
    out["missing"] = list(dict.fromkeys(log.missing[start:]))
    if doc is None:
        return out
    m = doc.get("means") or {}
    out["record"] = doc
    out["verdict"] = doc.get("verdict")
    out["headline"] = round_trip_verdict(doc)
    out["notes"] = [str(n) for n in doc.get("cycle_notes") or []]
    word = "generated" if (m.get("e_elec_j") or 0.0) < 0 else "drawn"
    sign = -1.0 if word == "generated" else 1.0
    out["rows"] = [
        ("session, scenario", f"{doc.get('session')}, {doc.get('scenario')}"),
        ("cycles kept", f"{doc.get('cycles_kept')} of {doc.get('cycles_in_profile')}"),
        ("sign convention", f"every energy below is electrical energy {word} per cycle "
         f"({'delivered to' if word == 'generated' else 'taken from'} the grid), positive; an "
         "error is the prediction against the measured energy"),
        (f"electrical energy {word} per cycle, measured [J]",
         f"{_energy(m.get('e_elec_j'), sign)} (95 %: +- {fmt(m.get('band_elec_j'), 1)})"),
        ("power model at the measured speed and torque [J]",
         f"{_energy(m.get('e_elec_model_j'), sign)}: "
         f"{prediction_words(m.get('model_error'), m.get('e_elec_j'))} "
         f"(band {_pct(m.get('model_error_band'))[1:]})"),
        ("optimizer's prediction [J]", f"{_energy(m.get('e_elec_optimizer_j'), sign)}: "
         f"{prediction_words(m.get('optimizer_error'), m.get('e_elec_j'))}"),
        (f"mechanical energy {word} per cycle, measured [J]",
         f"{_energy(m.get('e_mech_j'), sign)} (95 %: +- {fmt(m.get('band_mech_j'), 1)}); "
         f"optimizer {_energy(doc.get('e_mech_optimizer_j'), sign)}"),
        (f"drift of the energy {word} [J per cycle]",
         f"{_energy((doc.get('drift') or {}).get('slope_j_per_cycle'), sign, 2)}"
         f" +- {fmt((doc.get('drift') or {}).get('slope_u_j_per_cycle'), 2)}"),
    ]
    if one is not None and len(one):
        out["power_figure"] = power_figure(one, int(doc.get("one_cycle", 0)))
    if cycles is not None and len(cycles):
        out["energy_figure"] = energy_figure(cycles, float(doc.get("coverage_factor", 2.0)))
    return out
