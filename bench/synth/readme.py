"""The README.md written next to a generated campaign."""

from __future__ import annotations

from bench.synth.instruments import Instruments


def campaign_readme(seed: int, scale: int, sessions: dict, inst: Instruments) -> str:
    """Describe the campaign, its sessions and the exact command that made it."""
    scale_arg = "" if scale == 1 else f" --scale {scale}"
    lines = [
        "# Synthetic bench campaign",
        "",
        "Made by drivebench's deterministic generator (`bench synth`, package `bench/synth/`):",
        "",
        "```sh",
        f"bench synth raw_measurements --seed {seed}{scale_arg}",
        "```",
        "",
        "(any OUT_DIR in place of `raw_measurements`). "
        "Same seed and scale give byte-identical files. The layout and formats are those of",
        "docs/schemas.md section 1; `truth.json` holds the true loss model (a calibrated core",
        "quadratic plus friction, iron loss, gear-mesh loss, a temperature-driven cabinet fan",
        "and copper resistance drifting with the winding temperature), the instruments' error",
        "model, each session's clock offset and drift, and every true operating point",
        "(setpoints, steady-window bounds on the DAQ clock and the window means of the true",
        "signals, drum frame). Clock model per session: "
        "`t_daq_s = offset_s + (1 + drift_ppm * 1e-6) * t_analyzer_s`.",
        "",
        "The drive is the paper's 8.2 kW PMSM with a 1:3 gearbox (Stuyts et al. 2015, section",
        "III-B): motor mode 50..1500 rpm x 1..78 N m, generator mode 30..3000 rpm (drum speed",
        "negative) x 1..78 N m with at most 10 kW of shaft power.",
        "",
        f"DAQ (speed, torque) at {inst.daq_rate_hz:g} Hz; power analyzer every "
        f"{inst.analyzer_interval_s * 1000:g} ms on its own clock. Signals carry sensor noise, "
        f"a torque-flange zero offset of {inst.torque_zero_offset_nm:g} N m (at the measured "
        "shaft), setpoint transients, and isolated invalid-value markers "
        "(`9.91E+37`, `NAN`, `---`).",
        "",
        "| session | kind | mode | points | notes |",
        "|---|---|---|---:|---|",
    ]
    for sid, info in sessions.items():
        detail = [f"measured side {info['measured_side']}"]
        if info["speed_sign"] != 1:
            detail.append(f"speed_sign {info['speed_sign']}")
        if info["kind"] == "timeseries":
            detail.append(f"{info['daq_rows']} DAQ rows, {info['analyzer_rows']} analyzer rows")
        lines.append(f"| {sid} | {info['kind']} | {info['mode']} | {info['n_points']} | "
                     f"{'; '.join(detail)} |")
    lines += [
        "",
        "Formats: `motor_01` English CSV + analyzer in kW; `motor_02` German locale (`;`,",
        "decimal comma, units row) logged on the motor side of the gearbox; `generator_01`",
        "DAQ as NI TDMS with the speed logged as a positive magnitude; `generator_02` English",
        "CSV; `generator_table_03` a table of averaged points with foreign column names read",
        "through `mapping.toml`.",
        "",
    ]
    return "\n".join(lines)
