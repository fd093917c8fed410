"""The measured points against the torque-speed envelope the campaign's drive states.

A campaign's ``drive.toml`` may state the drive's envelope (a base speed or a datasheet
table, :class:`kernel.drive.Drive`). A point measured above it means the rating, the
log (a torque scale, a gear ratio) or the drive's operation is not what the campaign
says: ``bench fit`` counts such points and names the worst, and keeps them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: a point counts as above the envelope beyond this share of the torque limit (a bench
#: torque flange of accuracy class 0.1-0.5 % plus its zero offset)
TOLERANCE_FRAC = 0.01


def envelope_check(frame: pd.DataFrame, rating) -> dict | None:
    """Points above the drive's stated envelope.

    Parameters
    ----------
    frame : pandas.DataFrame
        Fitted points: ``session_id``, ``point_id``, ``speed_rpm``, ``torque_nm``.
    rating : kernel.drive.Drive
        The fit's rating; None is returned when it states no envelope.

    Returns
    -------
    dict or None
        ``envelope`` (the keys), ``tolerance_nm``, ``n_points``, ``n_above``, ``worst``
        (session, point, speed [rpm], torque [N m], the envelope's torque [N m]; None
        when no point is above) and ``note``.
    """
    if not rating.has_envelope():
        return None
    speed = frame["speed_rpm"].to_numpy(float)
    torque = np.abs(frame["torque_nm"].to_numpy(float))
    top = rating.largest_torque_nm(speed)
    tolerance = TOLERANCE_FRAC * rating.max_torque_nm
    excess = torque - top
    above = excess > tolerance
    out = {"envelope": rating.envelope, "tolerance_nm": tolerance, "n_points": int(len(frame)),
           "n_above": int(above.sum()), "worst": None}
    if not above.any():
        out["note"] = (f"every measured point lies within the drive's stated torque-speed "
                       f"envelope ({_stated(rating)}, {tolerance:.3g} N m tolerance)")
        return out
    k = int(np.argmax(excess))
    out["worst"] = {"session_id": str(frame["session_id"].iloc[k]),
                    "point_id": str(frame["point_id"].iloc[k]), "speed_rpm": float(speed[k]),
                    "torque_nm": float(torque[k]), "envelope_torque_nm": float(top[k])}
    out["note"] = (f"{out['n_above']} of {len(frame)} measured points lie above the drive's "
                   f"stated torque-speed envelope ({_stated(rating)}) by more than "
                   f"{tolerance:.3g} N m; the worst, {out['worst']['session_id']} point "
                   f"{out['worst']['point_id']}, at {speed[k]:.5g} rpm and {torque[k]:.4g} N m "
                   f"where the envelope gives {top[k]:.4g} N m: the rating, the log (torque "
                   "scale, gear ratio) or the drive's operation is not what the campaign states")
    return out


def _stated(rating) -> str:
    if rating.base_speed_rpm is not None:
        return f"constant power above {rating.base_speed_rpm:g} rpm"
    return f"a table of {len(rating.envelope_speed_rpm)} speeds"
