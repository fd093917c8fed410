"""Whether a drive's rating is one a real machine has, and what a carried loss model assumes.

**Peak power.** A machine runs at its nominal power continuously and above it only for a
short time, at the overload its datasheet states (``[drive] overload``: the short-time
torque over the continuous one). An airborne-wind-energy ground station's generator is
sized for the peak mechanical power of the reel-out phase, 2.5 times the rated electrical
(cycle-average) power in AWE-Power (R. Joshi, R. Schmehl, M. Kruijff, "Power curve
modelling and scaling of fixed-wing ground-generation airborne wind energy systems",
Wind Energ. Sci. 9, 2195-2215, 2024; its input ``peakM2E_F``, awegroup/AWE-Power):
:data:`PEAK_TO_RATED` is that factor, the limit where the rating states no overload. The
most shaft power a cycle can draw within the limits (:meth:`kernel.drive.Drive.peak_power_w`) is the
torque limit times the speed limit without an envelope, times the base speed with a
constant-power envelope, the largest torque times speed of a datasheet table (its last
torque held to the speed limit) otherwise. A rating whose peak exceeds that many times its
nominal power is no drive an engineer would recognize: :func:`power_check` says so, and
``bench optimize``, ``bench size`` and the report print it.

**Efficiency and size.** The similarity law (:func:`optimize.model.drivetrain.
carry_power_model`) keeps the base drive's efficiency at corresponding operating points.
Real machines grow more efficient with their rating: the IEC 60034-30-1 efficiency
classes rise with rated power (IE3, 4 poles, 50 Hz: 90.4 % at 7.5 kW, 96.0 % from 200 kW
up). ``[drive] scaling = "similarity"`` does not know that: :func:`efficiency_assumption`
says so whenever it carries losses to a larger drive. ``scaling = "similarity-ie3"``
does: the losses at corresponding points are multiplied by :func:`rating_loss_ratio`, the
IE3 class's per-unit loss ``1 - eta`` at the carried drive's nominal power over that at the
base drive's (:func:`ie3_efficiency`; the class's minimum efficiencies as Commission
Regulation (EU) 2019/1781, Annex I, states them, and UK SI 2021/745, Schedule 16), so a
drive keeps its place relative to the class while its rating changes;
:func:`efficiency_law` says so.
"""

from __future__ import annotations

import math
from typing import Any

from kernel.units import power_words

#: the largest peak shaft power a rating may allow per unit of its nominal power when it
#: states no overload: AWE-Power's peak mechanical to rated electrical power (see above)
PEAK_TO_RATED = 2.5
#: IEC 60034-30-1 IE3 efficiency, 4 poles, 50 Hz: (rated power [W], efficiency [-]) at the
#: class table's small and large end quoted in the assumption
IE3_4POLE = ((7.5e3, 0.904), (200e3, 0.960))
#: the IE3 class, 4 poles, 50 Hz, between 0.75 and 200 kW: efficiency [%] = A x^3 + B x^2 +
#: C x + D with x = log10(P / 1 kW); (A, B, C, D) of Regulation (EU) 2019/1781, Annex I
#: (UK SI 2021/745, Schedule 16, Table 28)
IE3_4POLE_ABCD = (0.0773, -1.8951, 9.2984, 83.7025)
#: the range of rated powers [W] the interpolation covers; above it the class is flat
#: (96.0 %) up to the regulation's largest motor, :data:`IE_SCOPE_W`
IE3_FORMULA_RANGE_W = (0.75e3, 200e3)
#: the IE3 class at 4 poles from 200 kW to 1000 kW [-] (the same regulation's table)
IE3_4POLE_FLAT = 0.960
#: the largest rated power [W] the efficiency classes cover (Regulation (EU) 2019/1781
#: applies to motors from 0.12 kW up to 1000 kW); above it the 1000 kW value is held
IE_SCOPE_W = 1000e3
#: a carried drive this many times the base drive's nominal power or more gets the line
EFFICIENCY_NOTE_RATIO = 1.5


def power_check(rating: Any, envelope: Any = None) -> str | None:
    """A sentence when the rating lets the drive deliver more shaft power than its nominal
    power times its overload (the stated ``overload``, else :data:`PEAK_TO_RATED`), else
    None."""
    peak = rating.peak_power_w(envelope)
    factor = rating.overload if rating.overload is not None else PEAK_TO_RATED
    if peak <= factor * rating.nominal_power_w * (1 + 1e-9):
        return None
    why = (f"its datasheet overload {factor:g}" if rating.overload is not None else
           f"{PEAK_TO_RATED:g}, AWE-Power's peak mechanical power of a ground station's "
           "generator per rated electrical power (Joshi et al. 2024)")
    return (f"drive rating not that of a real machine: {rating.box_text()} let a cycle draw "
            f"{power_words(peak)} "
            f"at the shaft, {peak / rating.nominal_power_w:.3g} times its nominal "
            f"{power_words(rating.nominal_power_w)}, above {why}: state a constant-power "
            "envelope ([drive] base_speed_rpm) or the datasheet's overload, or a nominal "
            "power that fits the limits")


def ie3_efficiency(power_w: float) -> float:
    """The IE3 class's minimum efficiency [-] (4 poles, 50 Hz) at a rated power [W]: the
    interpolation of :data:`IE3_4POLE_ABCD` between 0.75 and 200 kW, 96.0 % above (the
    class is flat from 200 to 1000 kW and held beyond, :data:`IE_SCOPE_W`); below 0.75 kW
    the 0.75 kW value is held."""
    lo, hi = IE3_FORMULA_RANGE_W
    if power_w >= hi:
        return IE3_4POLE_FLAT
    x = math.log10(max(float(power_w), lo) / 1e3)
    a, b, c, d = IE3_4POLE_ABCD
    return (((a * x + b) * x + c) * x + d) / 100.0


def rating_loss_ratio(base_power_w: float, power_w: float) -> float:
    """How the losses per unit of rating move from a drive of nominal power
    ``base_power_w`` to one of ``power_w`` [W]: the IE3 class's ``1 - eta`` at the
    second over that at the first (:func:`ie3_efficiency`)."""
    return (1.0 - ie3_efficiency(power_w)) / (1.0 - ie3_efficiency(base_power_w))


def efficiency_law(base_power_w: float, power_w: float) -> str:
    """The line that says how ``scaling = "similarity-ie3"`` moves efficiency with rating
    from a drive of nominal power ``base_power_w`` to one of ``power_w`` [W]."""
    powers = (base_power_w, power_w)
    held = [f"the {w / 1e3:g} kW value held {side}" for w, side, out in (
        (IE3_FORMULA_RANGE_W[0], "below it", min(powers) < IE3_FORMULA_RANGE_W[0]),
        (IE_SCOPE_W, "above it, beyond the classes' scope", max(powers) > IE_SCOPE_W)) if out]
    return (f"drive losses per unit of rating follow the IEC 60034-30-1 IE3 class (4 poles; "
            f"Regulation (EU) 2019/1781, Annex I): {100 * ie3_efficiency(base_power_w):.1f} % "
            f"at {power_words(base_power_w)}, {100 * ie3_efficiency(power_w):.1f} % at "
            f"{power_words(power_w)}" + (f" ({'; '.join(held)})" if held else "")
            + f", so the carried losses are x{rating_loss_ratio(*powers):.3g} the similarity "
            "law's at corresponding points")


def efficiency_assumption(nominal_ratio: float) -> str | None:
    """The line that says the similarity law keeps efficiency with size, when it carries
    losses to a drive ``nominal_ratio`` times the base drive's nominal power (at least
    :data:`EFFICIENCY_NOTE_RATIO`), else None."""
    if nominal_ratio < EFFICIENCY_NOTE_RATIO:
        return None
    (p0, e0), (p1, e1) = IE3_4POLE
    return (f"the similarity law carries the base drive's efficiency unchanged to a drive "
            f"{nominal_ratio:.3g} times its nominal power: it assumes efficiency does not rise "
            f"with rating, while IEC 60034-30-1's classes do (IE3, 4 poles: {100 * e0:.1f} % "
            f"at {p0 / 1e3:g} kW, {100 * e1:.1f} % from {p1 / 1e3:g} kW), so the carried "
            "losses are likely too large; a bench fit of the real drive replaces them")
