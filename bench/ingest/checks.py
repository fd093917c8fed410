"""Plausibility checks of a session's powers and operating points (table and timeseries paths).

What a wrong mapping or a mislabelled column looks like in the numbers, and the
check that catches it:

- a p_elec column that is zero or constant throughout: :func:`check_signal`;
- p_mech, p_elec, speed or torque in the wrong unit (``[W]`` holding kW, a
  mapped ``kNm`` that is N m, ``mW`` read as ``MW``), a swapped column: every
  point is checked by :func:`check_points` against the session's sensor ranges,
  against physics (losses ``p_elec - p_mech >= 0`` within noise: ``0 < eta <= 1``
  in motor mode, ``eta <= 1`` in generator mode) and, when the mapping names a
  p_mech column, against ``omega * T``. When more points fail than isolated
  outliers explain (:func:`too_many`), the mapping is wrong, not the points:
  ingest stops with an error naming the columns, the share and the unit it
  suspects (the single unit change that would make the points pass); a few
  failing points are rejected with their reason;
- losses that vanish (``p_elec`` equal to ``omega * T`` within the instruments'
  accuracy) on most points: the p_elec column holds mechanical power;
- efficiencies implausibly low on most high-power points (speed in rad/s read as
  rpm, a torque or power column in the wrong unit): a unit to suspect;
- a flipped torque or speed sign: :func:`check_torque_sign`.

All arrays are in the drum frame and our units (rpm, N m, W).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import binom

from bench.ingest.column_units import QUANTITY_KIND, TARGET_UNIT, alternatives
from kernel.errors import InputError
from kernel.units import RPM_PER_RAD_S

#: a point may read up to this multiple of a sensor's range (overload) [-]
RANGE_MARGIN = 1.25

#: losses may be negative by this fraction of max(|p_elec|, |p_mech|) (noise, calibration) [-]
LOSS_RTOL = 0.03

#: a logged p_mech agrees with omega*T within this fraction [-]
P_MECH_RTOL = 0.05

#: both tolerances are at least this fraction of the session's largest |omega*T| [-]
POWER_FLOOR_FRAC = 0.01

#: more than this fraction of failing points is a systematic error (stop), fewer are
#: rejected one by one, unless :data:`ISOLATED_RATE` cannot explain their number [-]
SYSTEMATIC_FRAC = 0.2

#: rate of isolated implausible points (a glitch, a brake slip, a mistyped row) a sound
#: session may hold [-], and the false-alarm probability of calling a sound session
#: systematically wrong: more failing points than a binomial draw at this rate gives with
#: this probability are a wrong mapping, not outliers (:func:`too_many`) [-]
ISOLATED_RATE = 0.03
FALSE_ALARM = 1e-3

#: a suspected unit must bring at least this fraction of the sensor range into use [-]
MIN_RANGE_USE = 0.01

#: rejection reasons (rejected/*.parquet)
REASON_RANGE = "outside sensor range"
REASON_ETA = "efficiency above 1"
REASON_P_MECH = "p_mech disagrees with omega*T"

#: p_elec below NEAR_ZERO_FRAC of |omega*T| on most points above HIGH_POWER_FRAC of the
#: session's largest |omega*T| is a unit error (a generator's p_elec may cross zero where
#: its losses equal the shaft power, but not everywhere); a systematic test only [-]
TEST_P_ELEC_SMALL = "p_elec near zero at high power"
HIGH_POWER_FRAC = 0.25
NEAR_ZERO_FRAC = 0.05

#: |p_elec - omega*T| within this fraction of max(|p_elec|, |omega*T|) is a loss the
#: instruments cannot tell from zero (a power analyzer's and a torque flange's accuracy
#: are each 0.05-0.1 % of reading): no drive is that efficient on most of its points [-]
TEST_ZERO_LOSS = "losses zero within the instruments' accuracy"
ZERO_LOSS_RTOL = 0.002

#: efficiency below LOW_EFFICIENCY on most points above HIGH_POWER_FRAC of the session's
#: largest power is a unit error (speed in rad/s read as rpm gives 1/9.55 of it): a drive
#: near its rating converts far more than a quarter of its power [-]
TEST_ETA_LOW = "efficiency implausibly low at high power"
LOW_EFFICIENCY = 0.25

#: at high |p_mech| this fraction of sign disagreements with p_elec means a flipped sign
SIGN_FLIP_FRAC = 0.8

#: ... and between MAX_SIGN_DISAGREEMENT and SIGN_FLIP_FRAC the data cannot tell
MAX_SIGN_DISAGREEMENT = 0.5


@dataclass(frozen=True)
class Source:
    """Where a quantity was read from (for messages).

    Parameters
    ----------
    path : Path
        The file.
    column : str
        Its column (or the mapping's expression).
    unit : str
        The unit it was read in.
    """

    path: Path
    column: str
    unit: str

    def describe(self) -> str:
        """``'P [W]' of analyzer.csv (read as W)``."""
        return f"{self.column!r} of {self.path.name} (read as {self.unit or 'no unit'})"


def sources_from_meta(path: Path, columns: dict) -> dict[str, Source]:
    """:class:`Source` per quantity from an instrument's manifest ``columns`` block."""
    return {q: Source(path, c["column"], c.get("unit", "")) for q, c in columns.items()}


def check_signal(source: Source, quantity: str, x: np.ndarray, constant_too: bool) -> None:
    """Raise when a column's valid values are all zero (or, if ``constant_too``, all equal).

    Parameters
    ----------
    source : Source
        Where ``x`` came from.
    quantity : str
        ``p_elec``, ``speed``, ``torque``.
    x : array
        Its values (NaN for invalid).
    constant_too : bool
        Refuse a constant column as well (p_elec: a drive's input power follows its load).
    """
    v = np.asarray(x, np.float64)
    v = v[np.isfinite(v)]
    if v.size < 3:
        return
    if not np.any(v):
        raise InputError(source.path, f"the {quantity} column is zero throughout ({v.size} "
                         "values)", column=source.column,
                         expected=f"the column that holds {quantity} (check the mapping)")
    if constant_too and np.ptp(v) <= 1e-12 * np.max(np.abs(v)):
        raise InputError(source.path, f"the {quantity} column holds one value ({v[0]:g}) "
                         f"throughout ({v.size} values)", column=source.column,
                         expected=f"a measured {quantity} that follows the operating point "
                         "(a status or setpoint column mapped by mistake?)")


def explicit_ranges(session) -> dict[str, float]:
    """The sensor ranges the session's ``[sensors]`` table states, seen from the drum.

    Ranges left to their defaults are not returned (they say nothing about this
    bench). Ranges are of the measured shaft: with ``measured_side = "motor"``
    the speed range is divided by the gear ratio and the torque range multiplied.

    Returns
    -------
    dict
        A subset of ``speed`` [rpm], ``torque`` [N m], ``power`` [W].
    """
    sensors = session.raw.get("sensors", {})
    gear = session.gear_ratio if session.measured_side == "motor" else 1.0
    keys = {"speed": ("speed_range_rpm", 1.0 / gear), "torque": ("torque_range_nm", gear),
            "power": ("power_range_w", 1.0)}
    return {q: session.ranges[q] * f for q, (k, f) in keys.items()
            if isinstance(sensors, dict) and k in sensors and session.ranges[q] > 0}


def _failures(v: dict[str, np.ndarray], ranges: dict[str, float]) -> dict[str, np.ndarray]:
    """Per test, the points failing it (bool arrays)."""
    omega_t = v["speed"] * v["torque"] / RPM_PER_RAD_S
    floor = POWER_FLOOR_FRAC * max(float(np.nanmax(np.abs(omega_t), initial=0.0)), 1e-9)
    out = {}
    over = np.zeros(omega_t.size, bool)
    for q, key in (("speed", "speed"), ("torque", "torque"), ("p_elec", "power")):
        if key in ranges:
            over |= np.abs(v[q]) > RANGE_MARGIN * ranges[key]
    out[REASON_RANGE] = over
    big = np.maximum(np.abs(v["p_elec"]), np.abs(omega_t))
    out[REASON_ETA] = v["p_elec"] - omega_t < -(LOSS_RTOL * big + floor)
    high = np.abs(omega_t) >= HIGH_POWER_FRAC * np.nanmax(np.abs(omega_t), initial=0.0)
    out[TEST_P_ELEC_SMALL] = high & (np.abs(v["p_elec"]) < NEAR_ZERO_FRAC * np.abs(omega_t))
    if "p_mech" in v:
        big = np.maximum(np.abs(v["p_mech"]), np.abs(omega_t))
        out[REASON_P_MECH] = np.abs(v["p_mech"] - omega_t) > P_MECH_RTOL * big + floor
    big = np.maximum(np.abs(v["p_elec"]), np.abs(omega_t))
    out[TEST_ZERO_LOSS] = (big > 0) & (np.abs(v["p_elec"] - omega_t) <= ZERO_LOSS_RTOL * big)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(omega_t > 0, omega_t / v["p_elec"], v["p_elec"] / omega_t)
    high = big >= HIGH_POWER_FRAC * np.nanmax(big, initial=0.0)
    out[TEST_ETA_LOW] = high & (big > 0) & ~(eta >= LOW_EFFICIENCY)
    return out


#: tests that only ever judge a whole session (never reject one point)
SESSION_TESTS = (TEST_P_ELEC_SMALL, TEST_ZERO_LOSS, TEST_ETA_LOW)


def too_many(k: int, n: int) -> bool:
    """Whether ``k`` failing points of ``n`` are more than isolated outliers explain.

    True when ``k`` exceeds :data:`SYSTEMATIC_FRAC` of ``n``, or when a binomial
    draw of ``n`` points at the outlier rate :data:`ISOLATED_RATE` gives ``k`` or
    more with a probability below :data:`FALSE_ALARM`. The share binds for small
    sessions (1 failing point of 4 is 25 %), the binomial tail for large ones (of
    2000 points, about 4 % fail at most by chance: 375 failing points are a wrong
    mapping, not 375 outliers).
    """
    if k <= 0 or n <= 0:
        return False
    if k > SYSTEMATIC_FRAC * n:
        return True
    return bool(binom.sf(k - 1, n, ISOLATED_RATE) < FALSE_ALARM)


def check_points(
    values: dict[str, np.ndarray], sources: dict[str, Source], ranges: dict[str, float],
    where: Path,
) -> list[str | None]:
    """Check every operating point; stop on a systematic error, else name the bad points.

    Parameters
    ----------
    values : dict
        Per point (drum frame): ``speed`` [rpm], ``torque`` [N m], ``p_elec`` [W],
        and ``p_mech`` [W] when a p_mech column is mapped.
    sources : dict
        :class:`Source` of each quantity in ``values``.
    ranges : dict
        Sensor ranges the session states (drum frame, :func:`explicit_ranges`);
        quantities without one are not range-checked.
    where : Path
        The session's data file (for the message when no column is to blame).

    Returns
    -------
    list
        Per point, None or the reason it is rejected (:data:`REASON_RANGE`,
        :data:`REASON_ETA`, :data:`REASON_P_MECH`).

    Raises
    ------
    InputError
        More points fail one test than isolated outliers explain
        (:func:`too_many`), or a session test fails (losses zero, efficiency
        implausibly low, p_elec near zero at high power): the message names the
        test, the share, the worst point, the columns involved and the unit change
        that would make the points pass (or says none does).
    """
    v = {q: np.asarray(x, np.float64) for q, x in values.items()}
    ok = np.ones(v["speed"].size, bool)
    for x in v.values():
        ok &= np.isfinite(x)
    n = int(ok.sum())
    reasons: list[str | None] = [None] * ok.size
    if n == 0:
        return reasons
    v_ok = {q: x[ok] for q, x in v.items()}
    fails = _failures(v_ok, ranges)
    test = _systematic_test(fails, v_ok)
    if test is not None:
        raise _systematic(test, fails[test], v_ok, sources, ranges, where)
    idx = np.flatnonzero(ok)
    for test in (REASON_RANGE, REASON_P_MECH, REASON_ETA):  # the first listed wins
        for k in np.flatnonzero(fails.get(test, np.zeros(n, bool))):
            if reasons[idx[k]] is None:
                reasons[idx[k]] = test
    return reasons


def _systematic_test(fails: dict[str, np.ndarray], v: dict[str, np.ndarray]) -> str | None:
    """The first test that fails on too many points to be a few bad points, or None."""
    n = v["speed"].size
    omega_t = np.abs(v["speed"] * v["torque"]) / RPM_PER_RAD_S
    big = np.maximum(np.abs(v["p_elec"]), omega_t)
    for test, bad in fails.items():
        if test in (TEST_P_ELEC_SMALL, TEST_ETA_LOW):
            ref = omega_t if test == TEST_P_ELEC_SMALL else big
            n_high = int((ref >= HIGH_POWER_FRAC * np.nanmax(ref, initial=0.0)).sum())
            if n_high >= 3 and bad.sum() > 0.5 * n_high:
                return test
        elif test == TEST_ZERO_LOSS:
            if n >= 3 and bad.sum() > 0.5 * n:
                return test
        elif too_many(int(bad.sum()), n):
            return test
    return None


def suspect_units(
    v: dict[str, np.ndarray], sources: dict[str, Source], ranges: dict[str, float],
) -> list[tuple[str, str, float]]:
    """Single unit changes that make the points pass every check.

    Returns
    -------
    list of (quantity, unit, factor)
        The quantity, the unit it would then be read in, and the factor that
        multiplies its values; best first (the sensor range used most closely
        to its full scale).
    """
    found = []
    for q, src in sources.items():
        if q not in v or q not in QUANTITY_KIND:
            continue
        kind = QUANTITY_KIND[q]
        for unit, ratio in alternatives(kind, src.unit):
            trial = dict(v)
            trial[q] = v[q] * ratio
            if _systematic_test(_failures(trial, ranges), trial) is not None:
                continue
            key = "power" if kind == "power" else q
            use = (float(np.nanmax(np.abs(trial[q]))) / ranges[key] if key in ranges
                   else None)
            if use is not None and use < MIN_RANGE_USE:
                continue  # passes, but would use a sliver of the sensor: implausible
            found.append((q, unit, ratio, abs(math.log10(use)) if use else 9.0))
    found.sort(key=lambda c: c[3])
    return [(q, u, r) for q, u, r, _ in found]


def _range_problem(bad: np.ndarray, v: dict[str, np.ndarray], sources: dict[str, Source],
                   ranges: dict[str, float]) -> tuple[str, list[str]]:
    """What is outside the sensor ranges, and the quantities to blame."""
    n = bad.size
    worst, blamed = [], []
    for q, key in (("speed", "speed"), ("torque", "torque"), ("p_elec", "power")):
        m = float(np.max(np.abs(v[q])))
        if key in ranges and m > RANGE_MARGIN * ranges[key]:
            unit = TARGET_UNIT[QUANTITY_KIND[q]]
            worst.append(f"{q} up to {m:,.6g} {unit} from {sources[q].describe()}, above "
                         f"the {key} sensor range {ranges[key]:,.6g} {unit}")
            blamed.append(q)
    return (f"{int(bad.sum())} of {n} points ({bad.sum() / n:.0%}) outside the sensor "
            "ranges: " + "; ".join(worst)), blamed


def _power_problem(test: str, bad: np.ndarray, v: dict[str, np.ndarray],
                   omega_t: np.ndarray) -> str:
    """What is wrong with p_elec against omega*T, with the worst point as an example."""
    n = bad.size
    motor = omega_t > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(motor, omega_t / v["p_elec"], v["p_elec"] / omega_t)
    k = int(np.argmax(np.where(bad, np.abs(omega_t), -np.inf)))
    quad = "motor" if motor[k] else "generator"
    what = {REASON_ETA: "p_elec is below omega*T (efficiency above 1)",
            TEST_P_ELEC_SMALL: f"p_elec is below {NEAR_ZERO_FRAC:.0%} of |omega*T| at "
                               "high power",
            TEST_ZERO_LOSS: f"p_elec equals omega*T within {ZERO_LOSS_RTOL:.1%} (losses "
                            "zero within the instruments' accuracy)",
            TEST_ETA_LOW: f"the efficiency is below {LOW_EFFICIENCY:.0%} at high power "
                          f"(median {float(np.nanmedian(eta[bad])):.3g})"}[test]
    what += (f" on {int(bad.sum())} of {n} points ({bad.sum() / n:.0%}), e.g. {quad} "
             f"point {v['speed'][k]:.6g} rpm, {v['torque'][k]:.6g} N m: omega*T = "
             f"{omega_t[k]:,.6g} W, p_elec = {v['p_elec'][k]:,.6g} W, efficiency "
             f"{eta[k]:.4g}")
    if test == REASON_ETA:
        what += (f"; more than isolated outliers (up to {ISOLATED_RATE:.0%} of the points) "
                 "explain: the mapping, not the points, is wrong")
    return what


def _p_mech_problem(bad: np.ndarray, v: dict[str, np.ndarray], omega_t: np.ndarray) -> str:
    """How a mapped p_mech disagrees with omega*T, with the worst point as an example."""
    n = bad.size
    k = int(np.argmax(np.where(bad, np.abs(v["p_mech"] - omega_t), -np.inf)))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = float(np.nanmedian(v["p_mech"][bad] / omega_t[bad]))
    return (f"the mapped p_mech disagrees with omega*T by more than {P_MECH_RTOL:.0%} on "
            f"{int(bad.sum())} of {n} points ({bad.sum() / n:.0%}; median ratio "
            f"{ratio:.4g}), e.g. "
            f"p_mech = {v['p_mech'][k]:,.6g} W against omega*T = {omega_t[k]:,.6g} W at "
            f"{v['speed'][k]:.6g} rpm, {v['torque'][k]:.6g} N m")


def _unit_hint(v: dict[str, np.ndarray], sources: dict[str, Source], ranges: dict[str, float],
               blamed: list[str], where: Path) -> tuple[str, Path, str | None]:
    """The unit change that explains the failure (or the columns to check) and the file and
    column to name."""
    suspects = suspect_units(v, sources, ranges)
    if suspects:
        q, unit, _ = suspects[0]
        src = sources[q]
        hint = f"suspect the {q} unit: {src.describe()} looks like {unit}"
        if len(suspects) > 1:
            hint += " (or " + ", ".join(f"{s} in {u}" for s, u, _ in suspects[1:3]) + ")"
        return hint, src.path, src.column
    hint = ("no single unit change explains it: check which columns the mapping names ("
            + ", ".join(f"{q}: {sources[q].describe()}" for q in blamed if q in sources)
            + ")")
    first = next((sources[q] for q in blamed if q in sources), None)
    path, column = (first.path, first.column) if first is not None else (where, None)
    return hint, path, column


def _systematic(test: str, bad: np.ndarray, v: dict[str, np.ndarray],
                sources: dict[str, Source], ranges: dict[str, float], where: Path) -> InputError:
    """The error of a check that fails on too many points to be a few bad ones."""
    omega_t = v["speed"] * v["torque"] / RPM_PER_RAD_S
    if test == REASON_RANGE:
        what, blamed = _range_problem(bad, v, sources, ranges)
    elif test in (REASON_ETA, TEST_P_ELEC_SMALL, TEST_ZERO_LOSS, TEST_ETA_LOW):
        what = _power_problem(test, bad, v, omega_t)
        blamed = ["p_elec", "torque", "speed"]
        if test == TEST_ZERO_LOSS:
            return InputError(
                sources["p_elec"].path if "p_elec" in sources else where,
                f"{what}: the electrical power column holds mechanical power (speed x "
                f"torque), not what the drive draws: {sources['p_elec'].describe()}"
                if "p_elec" in sources else what,
                column=sources["p_elec"].column if "p_elec" in sources else None,
                expected="the electrical power the drive draws from (or feeds into) the "
                "grid or DC link: a power analyzer's total, or U * I (mapping: expr)")
    else:
        what = _p_mech_problem(bad, v, omega_t)
        blamed = ["p_mech", "torque", "speed"]
    hint, path, column = _unit_hint(v, sources, ranges, blamed, where)
    return InputError(path, f"{what}; {hint}", column=column,
                      expected="the unit the column is really in (the mapping's 'unit'), or "
                      "the right column")


def check_torque_sign(session, p_mech_w, p_elec_w, where: Path) -> None:
    """Raise when p_mech and p_elec disagree in sign where |p_mech| is high.

    The drive's efficiency is high at high power, so there both powers share
    their sign. If nearly all such samples disagree (more than
    :data:`SIGN_FLIP_FRAC`), the torque (or speed) sign of the session is
    flipped and the error says which setting to change. If many but not nearly
    all disagree, the opposite sign would not fit either: the error says the
    data cannot decide and points at the columns and the alignment instead.
    High means above a quarter of the 95th percentile of |p_mech| and above 2 %
    of the session's power range.
    """
    ok = np.isfinite(p_mech_w) & np.isfinite(p_elec_w)
    if ok.sum() < 10:
        return
    pm, pe = p_mech_w[ok], p_elec_w[ok]
    high = np.abs(pm) > 0.25 * np.percentile(np.abs(pm), 95)
    high &= np.abs(pm) > 0.02 * session.ranges["power"]  # well above no-load losses
    if high.sum() < 5:
        return
    disagree = float(np.mean(np.sign(pm[high]) != np.sign(pe[high])))
    if disagree <= MAX_SIGN_DISAGREEMENT:
        return
    if disagree >= SIGN_FLIP_FRAC:
        # under "signed" the drum torque is >= 0 whatever torque_sign: only speed_sign flips
        fix = (f"speed_sign = {-session.speed_sign}" if session.signed_torque else
               f"torque_sign = {-session.torque_sign} (or a flipped speed_sign)")
        raise InputError(
            session.path,
            f"torque sign convention looks flipped: at high |p_mech| the signs of p_mech and "
            f"p_elec disagree in {disagree:.0%} of the samples of {where.name}",
            column="torque_sign",
            expected=f"{fix} so that generating points have p_mech < 0 and p_elec < 0; or, "
            "if the p_elec column logs generated power as positive, its negative (mapping: "
            "expr = \"-{column}\")",
        )
    raise InputError(
        session.path,
        f"the data cannot decide the torque sign: at high |p_mech| the signs of p_mech and "
        f"p_elec disagree in {disagree:.0%} of the {int(high.sum())} samples of {where.name}, "
        "and with the opposite sign they would disagree in the other "
        f"{1 - disagree:.0%}",
        column="torque_sign",
        expected="p_elec and speed x torque of one bench run, mapped from the right columns "
        "(a wrong p_elec column or misaligned clocks give this); torque_sign/speed_sign "
        "need no change for that",
    )


def efficiency_flags(points: dict[str, np.ndarray]) -> list[str]:
    """Kept points whose efficiency (paper eqs. 1-2) lies outside [0, 1] beyond the noise.

    A point with ``p_elec`` and ``p_mech`` of opposite signs, each larger than its
    uncertainty, has a negative efficiency: a generator point at which the drive draws
    power (its losses exceed the shaft power; real at high speed and little torque). It
    is a true measurement of the electrical power, so it is kept for the power model,
    and flagged here (the efficiency map sets it to 0, drawn white, as the paper does). Efficiencies
    above 1 are rejected by :func:`check_points`.

    Parameters
    ----------
    points : dict
        ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w`` and optionally
        ``p_elec_w_std``, ``p_mech_w_std`` per point (the store's points columns).

    Returns
    -------
    list of str
        One line per flagged point: its efficiency, speed, torque and both powers.
    """
    p_mech = np.asarray(points["p_mech_w"], np.float64)
    p_elec = np.asarray(points["p_elec_w"], np.float64)
    if p_mech.size == 0:
        return []
    floor = POWER_FLOOR_FRAC * float(np.nanmax(np.abs(p_mech)))
    u_elec = np.maximum(floor, 2 * np.nan_to_num(points.get("p_elec_w_std", 0.0)))
    u_mech = np.maximum(floor, 2 * np.nan_to_num(points.get("p_mech_w_std", 0.0)))
    bad = (p_mech * p_elec < 0) & (np.abs(p_elec) > u_elec) & (np.abs(p_mech) > u_mech)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(p_mech > 0, p_mech / p_elec, p_elec / p_mech)
    return [f"efficiency {eta[k]:.3g} outside [0, 1] at {points['speed_rpm'][k]:.0f} rpm, "
            f"{points['torque_nm'][k]:.3g} N m (p_mech {p_mech[k]:.4g} W, p_elec "
            f"{p_elec[k]:.4g} W: the drive draws power while the shaft drives it); kept for the "
            "power model, set to 0 (drawn white) in the efficiency map"
            for k in np.flatnonzero(bad)]
