"""Foreign bench exports with a known truth, for the mapping features.

- :func:`make_dyno_table`: a small dyno's operating-point table: tab separated,
  a title line and a date line before the header, torque in ``N mm``, both
  quadrants, read through ``skip_lines`` and a mapping.
- :func:`make_ev_table`: a production EV-motor bench's operating-point table
  with about 500 ``Name [unit]`` columns: speed to 12000 rpm, a 150 kW
  power-limited torque envelope in both quadrants, p_elec as the DC link's
  ``U * I`` (``expr``) or the sum of three wattmeters (``sum``), p_mech mapped
  in kW, and many distractor columns (one named like p_mech that is not).

Each writes ``root/<sid>/{session.toml, points file, mapping.toml}`` and returns
the drum-frame truth of every row and the loss coefficients (:func:`loss_w`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kernel.drive import Drive
from kernel.units import RPM_PER_RAD_S


def loss_w(speed_rpm, torque_nm, c0: float, c_speed: float, c_torque: float):
    """Drive losses [W]: no-load + speed^2 (iron, friction) + torque^2 (copper) terms."""
    return c0 + c_speed * np.asarray(speed_rpm) ** 2 + c_torque * np.asarray(torque_nm) ** 2


def true_eta(speed_rpm, torque_nm, loss: tuple[float, float, float]) -> np.ndarray:
    """True efficiency of the fixture drive (paper eqs. 1-2: motor p_mech / p_elec, generator
    p_elec / p_mech), NaN at zero mechanical power."""
    p_mech = np.asarray(speed_rpm) * np.asarray(torque_nm) / RPM_PER_RAD_S
    p_elec = p_mech + loss_w(speed_rpm, torque_nm, *loss)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p_mech > 0, p_mech / p_elec, np.where(p_mech < 0, p_elec / p_mech, np.nan))


def _session_toml(sid: str, mode: str, file: str, sensors: dict[str, float]) -> str:
    lines = [f'session_id = "{sid}"', 'kind = "operating_points"', f'mode = "{mode}"',
             'operator = "fixture"', 'date = "2021-03-12"', "gear_ratio = 1.0",
             'measured_side = "drum"', "speed_sign = 1", "torque_sign = 1", "",
             "[points]", f'file = "{file}"', 'mapping = "mapping.toml"', "", "[sensors]"]
    lines += [f"{k} = {v!r}" for k, v in sensors.items()]
    return "\n".join(lines) + "\n"


def _write_table_session(root: Path, sid: str, file: str, lines: list[str], mapping: str,
                         sensors: dict[str, float]) -> None:
    """Write ``root/<sid>/``: the table ``file`` (its ``lines``), ``mapping.toml`` and a
    motor-mode ``session.toml`` with these sensor ranges."""
    folder = root / sid
    folder.mkdir(parents=True)
    (folder / file).write_text("\n".join(lines) + "\n", encoding="utf-8")
    (folder / "mapping.toml").write_text(mapping, encoding="utf-8")
    (folder / "session.toml").write_text(_session_toml(sid, "motor", file, sensors))


def make_dyno_table(root: Path, sid: str = "dyno_01", seed: int = 11) -> dict[str, np.ndarray]:
    """A 2 kW dyno's table: ``N mm`` torque, two preamble lines, tab separated.

    Motor rows at +500..+3000 rpm, generator rows at -500..-3000 rpm, torque
    0.5..6 N m written in N mm; p_elec = p_mech + losses, printed in W to 0.1 W.
    """
    rng = np.random.default_rng(seed)
    speed = np.array([s * n for s in (1.0, -1.0) for n in (500.0, 1000.0, 2000.0, 3000.0)
                      for _ in range(4)])
    torque = rng.uniform(0.5, 6.0, speed.size)
    p_mech = speed * torque / RPM_PER_RAD_S
    p_elec = p_mech + loss_w(speed, torque, 15.0, 2e-6, 0.8)
    rows = ["Dyno 3 – efficiency sweep, motor SN 4711", "Date\t12.03.2021",
            "Nr\tDrehzahl [1/min]\tMoment [N mm]\tP_el [W]\tT_Wicklung [°C]"]
    rows += [f"{k + 1}\t{s:.1f}\t{q * 1e3:.2f}\t{pe:.1f}\t{40 + k * 0.3:.1f}"
             for k, (s, q, pe) in enumerate(zip(speed, torque, p_elec, strict=True))]
    _write_table_session(
        root, sid, "points.txt", rows,
        'skip_lines = 2            # the title and the date line\n\n'
        '[columns.torque]\ncolumn = "Moment [N mm]"\nunit = "N mm"\n\n'
        '[columns.p_elec]\ncolumn = "P_el [W]"\nunit = "W"\n',
        {"torque_range_nm": 10.0, "speed_range_rpm": 4000.0, "power_range_w": 3000.0})
    return {"speed_rpm": speed, "torque_nm": torque, "p_elec_w": p_elec, "p_mech_w": p_mech,
            "loss": (15.0, 2e-6, 0.8)}


#: The EV motor of :func:`make_ev_table`: 300 N m to its base speed, 150 kW above it.
EV_MOTOR = Drive.rating(150e3, 12_000.0, 300.0, base_speed_rpm=150e3 / 300.0 * RPM_PER_RAD_S,
                        source="bench.synth.exports")


def make_ev_table(root: Path, sid: str = "ev_01", p_elec_by: str = "expr", n_columns: int = 500,
                  seed: int = 5) -> dict[str, np.ndarray]:
    """An EV-motor bench's operating-point export with ``n_columns`` ``Name [unit]`` columns.

    Parameters
    ----------
    p_elec_by : str
        ``"expr"``: p_elec mapped as ``{U_DC [V]} * {I_DC [A]}``; ``"sum"``:
        as the sum of ``P_1 [kW]``, ``P_2 [kW]``, ``P_3 [kW]`` (three wattmeters,
        unequal shares).
    """
    rng = np.random.default_rng(seed)
    grid = [(s * n, f) for s in (1.0, -1.0) for n in np.arange(1000.0, 12001.0, 1000.0)
            for f in (0.15, 0.4, 0.7, 0.95)]
    speed = np.array([n for n, _ in grid])
    torque = np.array([f for _, f in grid]) * EV_MOTOR.largest_torque_nm(speed)
    p_mech = speed * torque / RPM_PER_RAD_S
    p_elec = p_mech + loss_w(speed, torque, 400.0, 2e-5, 0.04)
    u_dc = 400.0 + rng.normal(0.0, 2.0, speed.size)
    i_dc = p_elec / u_dc
    share = np.array([0.34, 0.33, 0.33])
    cols: dict[str, list[str]] = {
        "Step [-]": [str(k + 1) for k in range(speed.size)],
        "Speed [rpm]": [f"{x:.2f}" for x in speed],
        "Torque_Flange [Nm]": [f"{x:.3f}" for x in torque],
        "P_Mech [kW]": [f"{x / 1e3:.5f}" for x in p_mech],
        "P_Mech_Setpoint [kW]": [f"{x / 1e3 * 0.9:.3f}" for x in p_mech],  # not p_mech
        "U_DC [V]": [f"{x:.3f}" for x in u_dc],
        "I_DC [A]": [f"{x:.4f}" for x in i_dc],
    }
    for k in range(3):
        cols[f"P_{k + 1} [kW]"] = [f"{x / 1e3:.5f}" for x in share[k] * p_elec]
    filler_units = ("°C", "V", "A", "mWb", "Hz", "bar", "%", "l/min")
    k = 0
    while len(cols) < n_columns:
        unit = filler_units[k % len(filler_units)]
        cols[f"Aux_{k:03d} [{unit}]"] = [f"{v:.3f}" for v in rng.normal(50.0, 5.0, speed.size)]
        k += 1
    names = list(cols)
    lines = [",".join(names)] + [",".join(cols[c][r] for c in names) for r in range(speed.size)]
    if p_elec_by == "expr":
        p_elec_entry = 'expr = "{U_DC [V]} * {I_DC [A]}"\nunit = "W"\n'
    else:
        p_elec_entry = 'sum = ["P_1 [kW]", "P_2 [kW]", "P_3 [kW]"]\nunit = "kW"\n'
    _write_table_session(
        root, sid, "export.csv", lines,
        '[columns.speed]\ncolumn = "Speed [rpm]"\nunit = "rpm"\n\n'
        '[columns.torque]\ncolumn = "Torque_Flange [Nm]"\nunit = "Nm"\n\n'
        f"[columns.p_elec]\n{p_elec_entry}\n"
        '[columns.p_mech]\ncolumn = "P_Mech [kW]"\nunit = "kW"\n',
        {"torque_range_nm": 400.0, "speed_range_rpm": 15000.0, "power_range_w": 200e3})
    return {"speed_rpm": speed, "torque_nm": torque, "p_elec_w": p_elec, "p_mech_w": p_mech,
            "u_dc_v": u_dc, "loss": (400.0, 2e-5, 0.04)}


def make_two_wattmeter_table(root: Path, sid: str = "aron_01", channels: int = 2, n: int = 240,
                             seed: int = 17) -> dict[str, np.ndarray]:
    """A power analyzer's operating-point export in 3V3A (two-wattmeter, Aron) wiring.

    The analyzer logs three elements ``P1 [W]``, ``P2 [W]``, ``P3 [W]``; in 3V3A
    wiring the total active power is ``P1 + P2`` (for line-to-line voltage ``U``,
    current ``I`` and phase angle ``phi``: ``U I cos(30° + phi) + U I cos(30° - phi)
    = sqrt(3) U I cos(phi)``), and the third element reads ``-U I sin(phi)``, a
    reactive share that belongs in no sum. ``channels = 3`` maps the sum of all
    three, as for a three-wattmeter (3P4W) export: wrong, by ``-tan(phi)/sqrt(3)``
    of the power, so points with a leading phase show an efficiency above 1.

    Both quadrants of a 5 kW drive, the phase angle uniform in -35°..+12° (motor;
    the generator's is 180° off).
    """
    if channels not in (2, 3):
        raise ValueError("channels: 2 (the right 3V3A total) or 3 (a wrong sum)")
    rng = np.random.default_rng(seed)
    speed = rng.uniform(300.0, 3000.0, n) * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    torque = rng.uniform(2.0, 16.0, n)
    p_mech = speed * torque / RPM_PER_RAD_S
    loss = (60.0, 1e-5, 0.6)
    p_elec = p_mech + loss_w(speed, torque, *loss)
    phi = np.deg2rad(rng.uniform(-35.0, 12.0, n)) + np.where(p_elec < 0, np.pi, 0.0)
    ui = np.abs(p_elec) / (np.sqrt(3.0) * np.abs(np.cos(phi)))  # U * I [W]
    p1 = ui * np.cos(np.pi / 6 + phi)
    p2 = ui * np.cos(np.pi / 6 - phi)
    p3 = -ui * np.sin(phi)
    rows = ["Point,Speed [rpm],Torque [Nm],P1 [W],P2 [W],P3 [W],PF [-]"]
    rows += [f"{k + 1},{s:.2f},{q:.4f},{a:.3f},{b:.3f},{c:.3f},{np.cos(f):.4f}"
             for k, (s, q, a, b, c, f) in enumerate(zip(speed, torque, p1, p2, p3, phi,
                                                         strict=True))]
    summed = ", ".join(f'"P{k + 1} [W]"' for k in range(channels))
    _write_table_session(
        root, sid, "analyzer_points.csv", rows,
        '[columns.speed]\ncolumn = "Speed [rpm]"\nunit = "rpm"\n\n'
        '[columns.torque]\ncolumn = "Torque [Nm]"\nunit = "Nm"\n\n'
        f'[columns.p_elec]\nsum = [{summed}]\nunit = "W"\n',
        {"torque_range_nm": 20.0, "speed_range_rpm": 4000.0, "power_range_w": 10000.0})
    return {"speed_rpm": speed, "torque_nm": torque, "p_elec_w": p_elec, "p_mech_w": p_mech,
            "p_elec_3_w": p1 + p2 + p3, "loss": loss}


def make_hobby_dyno_table(root: Path, sid: str = "hobby_01", seed: int = 23,
                          outlier: bool = True) -> dict[str, np.ndarray]:
    """A hobby dyno's motor-only table: 19 speeds x 18 torques, torque in ``N mm``.

    A 2.5 kW motor whose losses (no-load 4 W, friction 0.002 W/rpm, iron 0.8e-6
    W/rpm^2, copper 40 W/(N m)^2) put the peak efficiency (about 0.87) at part
    load (0.5-1.5 N m of 6) and high speed, 2000-4000 rpm, where one point's
    noise in efficiency is largest; full torque runs at 0.6-0.7. P_el is noisy (0.5 W)
    and printed to 0.01 W;
    the table states no std. With ``outlier``, one row (1811 rpm, 0.0004 N m,
    322 W) is a logging glitch: about 300 W above the drive's losses there.

    Returns the written rows' truth (``p_elec_w`` as written) and ``outlier_row``
    (its index, or -1).
    """
    rng = np.random.default_rng(seed)
    speed = np.repeat(np.linspace(500.0, 4000.0, 19), 18)
    torque = np.tile(np.linspace(0.05, 6.0, 18), 19)
    speed = speed + rng.normal(0.0, 2.0, speed.size)
    p_mech = speed * torque / RPM_PER_RAD_S
    loss = 4.0 + 0.002 * speed + 0.8e-6 * speed**2 + 40.0 * torque**2
    p_elec = p_mech + loss + rng.normal(0.0, 0.5, speed.size)
    row = -1
    if outlier:
        row = 7 * 18 + 1
        speed[row], torque[row], p_elec[row] = 1811.0, 0.0004, 322.0
        p_mech[row] = speed[row] * torque[row] / RPM_PER_RAD_S
    rows = ["Hobby dyno run 7", "Nr\tn [1/min]\tM [N mm]\tP_el [W]"]
    rows += [f"{k + 1}\t{s:.1f}\t{q * 1e3:.1f}\t{pe:.2f}"
             for k, (s, q, pe) in enumerate(zip(speed, torque, p_elec, strict=True))]
    _write_table_session(
        root, sid, "points.txt", rows,
        'skip_lines = 1\n\n[columns.speed]\ncolumn = "n [1/min]"\nunit = "1/min"\n\n'
        '[columns.torque]\ncolumn = "M [N mm]"\nunit = "N mm"\n\n'
        '[columns.p_elec]\ncolumn = "P_el [W]"\nunit = "W"\n',
        {"torque_range_nm": 10.0, "speed_range_rpm": 5000.0, "power_range_w": 5000.0})
    return {"speed_rpm": np.round(speed, 1), "torque_nm": np.round(torque * 1e3, 1) / 1e3,
            "p_elec_w": np.round(p_elec, 2), "outlier_row": row}
