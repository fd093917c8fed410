"""The README.md written next to a generated campaign."""

from __future__ import annotations

from bench.synth.instruments import Instruments
from bench.synth.plan import CAMPAIGN
from bench.synth.true_signals import DEFAULT_DYNAMICS as dyn

_DAQ = {"csv_en": "CSV (English)", "csv_de": "CSV (German: `;`, decimal comma, units row)",
        "tdms": "NI TDMS"}
_ANALYZER = {"en_kw": "vendor CSV, kW", "en_w": "vendor CSV, W",
             "de_w": "vendor CSV (German: `;`, decimal comma, units row), W"}


def campaign_readme(seed: int, scale: int, sessions: dict, calibration: dict,
                    inst: Instruments, thermal: dict) -> str:
    """Describe the campaign, its sessions and the exact command that made it.

    ``thermal`` is ``truth.json``'s ``thermal`` section (the winding's true thermal model).
    """
    return "\n".join([*_intro_lines(seed, scale, calibration, inst),
                      *_thermal_lines(thermal, inst), *_table_head(),
                      *_session_rows(sessions), ""])


def _thermal_lines(thermal: dict, inst: Instruments) -> list[str]:
    """The winding sensor and the thermal truth, in words."""
    return [
        "Every timeseries session's DAQ file also logs the winding temperature (degC;",
        "generator_01's TDMS in K): a sensor with a first-order lag of "
        f"{inst.winding_lag_s:g} s and {inst.winding_noise_k:g} K",
        "of white noise on the true winding temperature. The truth (`truth.json` `thermal`;",
        "each session's ambient is `ambient_c`): one thermal node, `tau_th_s dtheta/dt =",
        "ambient_c + r_th_k_per_w * heat_w - theta`, with the heat the losses",
        "`p_elec_w - p_mech_w` less the cabinet fan's power; "
        f"r_th_k_per_w = {thermal['r_th_k_per_w']:g} K/W,",
        f"tau_th_s = {thermal['tau_th_s']:g} s (c_th_j_per_k = {thermal['c_th_j_per_k']:g} J/K), "
        f"and the copper part of the T^2 loss drifts by {thermal['copper_temp_coeff_per_k']:g} / K",
        f"from theta_ref_c = {thermal['theta_ref_c']:g} degC.",
        "",
    ]


def _table_head() -> list[str]:
    return [
        "| session | kind | mode | points | faulty | files | notes |",
        "|---|---|---|---:|---:|---|---|",
    ]


def _intro_lines(seed: int, scale: int, calibration: dict, inst: Instruments) -> list[str]:
    """The command, the drive, the truth, the instruments and the faults, in words."""
    scale_arg = "" if scale == 1 else f" --scale {scale}"
    nominal = calibration["nominal_power_w"]
    lines = [
        "# Synthetic bench campaign",
        "",
        "Made by drivebench's deterministic generator (`bench synth`, package `bench/synth/`):",
        "",
        "```sh",
        f"bench synth raw_measurements --seed {seed}{scale_arg}",
        "```",
        "",
        "Any output folder in place of `raw_measurements` gets the same bytes: same seed and",
        "scale give byte-identical files. Layout and formats: docs/schemas.md section 1.",
        "",
        "The drive is the paper's 8.2 kW PMSM with a 1:3 gearbox (Stuyts et al. 2015, section",
        "III-B): motor mode 50..1500 rpm x 1..78 N m, generator mode 30..3000 rpm (drum speed",
        "negative) x 1..78 N m with at most 10 kW of shaft power. `drive.toml` states its",
        "rating (nominal power, drum-side speed and torque limits) and where the numbers come",
        "from; `bench fit` carries it into `power_model.json`.",
        "",
        "`truth.json` holds the true loss model (a core quadratic plus friction, iron loss,",
        "gear-mesh loss, a temperature-driven cabinet fan and copper resistance drifting with",
        "the winding temperature), the instruments' error model, each session's clock offset",
        "and drift (`t_daq_s = offset_s + (1 + drift_ppm * 1e-6) * t_analyzer_s`), and every",
        "true operating point (setpoints, steady-window bounds on the DAQ clock, window means",
        "of the true signals; drum frame). The core was calibrated so that an OLS fit of the",
        "paper's quadratic to the true points returns the paper's coefficients; the fit's",
        f"residual std is {100 * calibration['residual_std_w'] / nominal:.2f} % and its maximum",
        f"{100 * calibration['residual_max_abs_w'] / nominal:.2f} % of {nominal:g} W.",
        "",
        f"DAQ (speed, torque) at {inst.daq_rate_hz:g} Hz; power analyzer every "
        f"{inst.analyzer_interval_s * 1000:g} ms on its own clock.",
        "Signals carry sensor noise, a torque-flange zero offset of "
        f"{inst.torque_zero_offset_nm:g} N m (at the measured shaft), setpoint transients, "
        "and isolated invalid-value markers (`9.91E+37`, `NAN`, `---`, empty cells).",
        f"Each timeseries session starts with a tare: {dyn.tare_s:g} to "
        f"{dyn.tare_s + dyn.tare_jitter_s:g} s at standstill without load",
        "(true torque 0), so the flange's zero offset can be read off before the first step.",
        "",
        "A few setpoints of each timeseries session (1 to 3 %) are unusable, as on a real",
        "bench, and `truth.json` lists them (`bad_points`, and the `fault` column of the",
        "points): the particle brake hunting at low speed (speed oscillating), the load not",
        "holding its torque setpoint (torque sagging through the window), and the operator",
        "stepping to the next setpoint before a steady window was logged. The loss model's",
        "calibration and the figures above use the good points only.",
        "",
    ]
    return lines


def _session_rows(sessions: dict) -> list[str]:
    """One row of the sessions' table per session (its truth ``info``)."""
    lines = []
    specs = {s.session_id: s for s in CAMPAIGN}
    for sid, info in sessions.items():
        spec = specs[sid]
        detail = [f"measured side {info['measured_side']}"]
        if info["speed_sign"] != 1:
            detail.append(f"speed_sign {info['speed_sign']}")
        if info["kind"] == "timeseries":
            files = f"DAQ {_DAQ[spec.daq_format]}; analyzer {_ANALYZER[spec.analyzer_style]}"
            detail.append(f"{info['daq_rows']} DAQ rows, {info['analyzer_rows']} analyzer rows")
        else:
            files = "averaged points, foreign column names, `mapping.toml`"
        bad = len(info.get("bad_points", []))
        lines.append(f"| {sid} | {info['kind']} | {info['mode']} | {info['n_points']} | "
                     f"{bad} | {files} | {'; '.join(detail)} |")
    return lines
