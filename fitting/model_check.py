"""Is a drive power model physically possible where the optimizer may use it?

A model that passes the schema checks of :mod:`fitting.model_schema` can still be
impossible: a negative ``T^2`` coefficient, an offset of -1 MW, all zeros or a
coefficient of 1e250 each "converge" in the optimizer to a silently wrong
cycle. :func:`physics_problems` evaluates the model on grids over its measured
domain (each quadrant's polygon) and over the operating region the optimizer
may use (both quadrants of the box the drive limits in force span: speed
``-max..max``, torque ``0..max``), and names what is wrong and where:

* the power is not finite;
* the losses ``P_elec - P_mech`` (``P_mech = omega * T``) are negative by more
  than :data:`LOSS_TOLERANCE` of the model's own largest loss magnitude there
  (never of the nominal power the file claims, which a wrong file can inflate):
  the drive would make energy;
* ``|P_elec|`` exceeds :data:`MAGNITUDE_FACTOR` times the largest mechanical
  power of the region: not a drive of these limits;
* ``P_elec`` does not vary over the region (e.g. all coefficients zero).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fitting.domain import in_polygon
from fitting.power_model import PowerModel
from kernel.errors import InputError
from kernel.units import RPM_PER_RAD_S

#: grid nodes per axis over a region's bounding box, and per polygon edge
GRID_NODES = 41
#: negative losses allowed, as a fraction of the largest |P_elec - P_mech| of the
#: checked region: a least-squares fit scatters a little below zero loss near the
#: edges, far less than the losses it models
LOSS_TOLERANCE = 0.1
#: largest plausible |P_elec| relative to the largest |P_mech| of the region
MAGNITUDE_FACTOR = 10.0
#: smallest plausible spread of P_elec over the region, fraction of its largest |P_mech|
MIN_SPREAD = 1e-3


def check_regions(model: PowerModel, limits: tuple[float, float] | None = None
                  ) -> list[tuple[str, np.ndarray]]:
    """The regions the model is checked on: (label, polygon [rpm, N m]) each.

    Parameters
    ----------
    model : PowerModel
    limits : (float, float), optional
        The drive limits in force, speed [rpm] and torque [N m]
        (:meth:`kernel.drive.Drive.box`): the optimizer may use the motor quadrant
        ``[0, max_speed] x [0, max_torque]`` and its mirror in speed (generator),
        measured or not.

    Returns
    -------
    list
        The measured domain's quadrants, then the limits' quadrants.
    """
    regions = [(f"{q} quadrant (measured domain)", np.asarray(p, float))
               for q, p in (model.domain or {}).items() if len(p) >= 3]
    if limits is not None:
        s, t = limits
        where = f"within the drive limits the optimizer may use ({s:g} rpm, {t:g} N m)"
        regions += [(f"motor quadrant {where}", np.array([[0, 0], [s, 0], [s, t], [0, t]],
                                                         float)),
                    (f"generator quadrant {where}",
                     np.array([[-s, 0], [0, 0], [0, t], [-s, t]], float))]
    return regions


def _nodes(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interior grid nodes, vertices and points along every edge of ``poly``."""
    u = np.linspace(0.0, 1.0, GRID_NODES)
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    gx, gy = np.meshgrid(lo[0] + u * (hi[0] - lo[0]), lo[1] + u * (hi[1] - lo[1]))
    keep = in_polygon(poly, gx.ravel(), gy.ravel())
    edges = [a + np.outer(u, b - a) for a, b in zip(poly, np.roll(poly, -1, axis=0),
                                                     strict=True)]
    pts = np.vstack([np.column_stack([gx.ravel()[keep], gy.ravel()[keep]]), *edges])
    return pts[:, 0], pts[:, 1]


def physics_problems(model: PowerModel, limits: tuple[float, float] | None = None
                     ) -> list[str]:
    """What makes ``model`` physically impossible where it may be used (empty: nothing).

    Parameters
    ----------
    model : PowerModel
    limits : (float, float), optional
        The drive limits in force (see :func:`check_regions`).

    Returns
    -------
    list of str
        One sentence per problem, naming the region and operating point.
    """
    regions = check_regions(model, limits)
    if not regions:
        return ["no validity domain in the file and no drive limits to check it on"]
    problems = []
    spread = []
    for label, poly in regions:
        speed, torque = _nodes(poly)
        with np.errstate(over="ignore", invalid="ignore"):
            p_elec = model.p_elec_w(speed, torque)
        p_mech = speed / RPM_PER_RAD_S * torque
        bad = ~np.isfinite(p_elec)
        if bad.any():
            k = int(np.argmax(bad))
            problems.append(f"{label}: P_elec is not finite at {speed[k]:.4g} rpm, "
                            f"{torque[k]:.4g} N m")
            continue
        loss = p_elec - p_mech
        k = int(np.argmin(loss))
        if loss[k] < -LOSS_TOLERANCE * np.max(np.abs(loss)):
            problems.append(
                f"{label}: negative losses P_elec - P_mech = {loss[k]:.4g} W at "
                f"{speed[k]:.4g} rpm, {torque[k]:.4g} N m (P_elec {p_elec[k]:.4g} W, "
                f"P_mech {p_mech[k]:.4g} W): the drive would make energy")
        scale = float(np.max(np.abs(p_mech)))
        k = int(np.argmax(np.abs(p_elec)))
        if abs(p_elec[k]) > MAGNITUDE_FACTOR * scale:
            problems.append(
                f"{label}: |P_elec| = {abs(p_elec[k]):.4g} W at {speed[k]:.4g} rpm, "
                f"{torque[k]:.4g} N m is {abs(p_elec[k]) / scale:.3g} times the largest "
                f"mechanical power there ({scale:.4g} W): implausible for this drive")
        spread.append((p_elec, scale))
    if spread and not problems:
        values = np.concatenate([v for v, _ in spread])
        scale = max(sc for _, sc in spread)
        if math.isclose(float(np.ptp(values)), 0.0, abs_tol=MIN_SPREAD * scale):
            problems.append(f"P_elec is {values[0]:.4g} W everywhere in the checked "
                            "region: it does not depend on speed and torque")
    return problems


def check_physics(model: PowerModel, path: str | Path | None,
                  limits: tuple[float, float] | None = None) -> None:
    """Raise an InputError naming ``path`` when :func:`physics_problems` finds any."""
    problems = physics_problems(model, limits)
    if problems:
        raise InputError(path, "physically impossible power model: " + "; ".join(problems),
                         expected="losses P_elec - P_mech >= 0 and a plausible magnitude "
                                  "over the model's domain (bench fit writes such a model)")
