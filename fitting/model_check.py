"""Is a drive power model physically possible over its validity domain?

A model that passes the schema checks of :mod:`fitting.model_schema` can still be
impossible: a negative ``T^2`` coefficient, an offset of -1 MW, all zeros or a
coefficient of 1e250 each "converge" in the optimizer to a silently wrong
cycle. :func:`physics_problems` evaluates the model on a grid over its domain
(each quadrant's polygon; a box from the drive's limits where the file has no
domain) and names what is wrong:

* the power is not finite;
* the losses ``P_elec - P_mech`` (``P_mech = omega * T``) are negative by more
  than :data:`LOSS_TOLERANCE` of the nominal power: the drive would make energy;
* ``|P_elec|`` exceeds :data:`MAGNITUDE_FACTOR` times the larger of the nominal
  power and the mechanical power there: not the drive the file claims;
* ``P_elec`` does not vary over the domain (e.g. all coefficients zero).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bench.errors import InputError
from bench.units import RPM_PER_RAD_S
from fitting.domain import in_polygon
from fitting.power_model import PowerModel

#: grid nodes per axis over a quadrant's bounding box, and per polygon edge
GRID_NODES = 41
#: negative losses allowed, as a fraction of the nominal power: a least-squares fit
#: scatters by a few per cent of nominal at the domain's edge
LOSS_TOLERANCE = 0.02
#: largest plausible |P_elec| relative to max(nominal power, |P_mech|) at a node
MAGNITUDE_FACTOR = 10.0
#: smallest plausible spread of P_elec over the domain, fraction of the nominal power
MIN_SPREAD = 1e-3


def domain_nodes(model: PowerModel, limits: tuple[float, float] | None = None
                 ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Grid nodes (speed [rpm], torque [N m]) per quadrant of the model's validity domain.

    Parameters
    ----------
    model : PowerModel
    limits : (max_speed_rpm, max_torque_nm), optional
        The drive's limits, for a model file without a domain: the motor quadrant
        is then ``[0, max_speed] x [0, max_torque]``, the generator quadrant its
        mirror in speed.

    Returns
    -------
    dict
        quadrant -> (speed_rpm, torque_nm) arrays: interior grid nodes, the
        vertices and points along every edge.
    """
    if model.domain:
        polys = {q: np.asarray(p, float) for q, p in model.domain.items() if len(p) >= 3}
    elif limits is not None:
        s, t = limits
        polys = {"motor": np.array([[0, 0], [s, 0], [s, t], [0, t]], float),
                 "generator": np.array([[-s, 0], [0, 0], [0, t], [-s, t]], float)}
    else:
        polys = {}
    nodes = {}
    u = np.linspace(0.0, 1.0, GRID_NODES)
    for q, poly in polys.items():
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        gx, gy = np.meshgrid(lo[0] + u * (hi[0] - lo[0]), lo[1] + u * (hi[1] - lo[1]))
        keep = in_polygon(poly, gx.ravel(), gy.ravel())
        edges = [a + np.outer(u, b - a) for a, b in zip(poly, np.roll(poly, -1, axis=0),
                                                         strict=True)]
        pts = np.vstack([np.column_stack([gx.ravel()[keep], gy.ravel()[keep]]), *edges])
        nodes[q] = (pts[:, 0], pts[:, 1])
    return nodes


def physics_problems(model: PowerModel, limits: tuple[float, float] | None = None
                     ) -> list[str]:
    """What makes ``model`` physically impossible over its domain (empty: nothing).

    Parameters
    ----------
    model : PowerModel
    limits : (max_speed_rpm, max_torque_nm), optional
        Used when the model has no domain (see :func:`domain_nodes`).

    Returns
    -------
    list of str
        One sentence per problem, naming the quadrant and operating point.
    """
    nodes = domain_nodes(model, limits)
    if not nodes:
        return ["no validity domain in the file and no drive limits to check it on"]
    nominal = model.nominal_power_w
    problems = []
    spread = []
    for q, (speed, torque) in nodes.items():
        with np.errstate(over="ignore", invalid="ignore"):
            p_elec = model.p_elec_w(speed, torque)
        p_mech = speed / RPM_PER_RAD_S * torque
        bad = ~np.isfinite(p_elec)
        if bad.any():
            k = int(np.argmax(bad))
            problems.append(f"{q} quadrant: P_elec is not finite at {speed[k]:.4g} rpm, "
                            f"{torque[k]:.4g} N m")
            continue
        loss = p_elec - p_mech
        k = int(np.argmin(loss))
        if loss[k] < -LOSS_TOLERANCE * nominal:
            problems.append(
                f"{q} quadrant: negative losses P_elec - P_mech = {loss[k]:.4g} W at "
                f"{speed[k]:.4g} rpm, {torque[k]:.4g} N m (P_elec {p_elec[k]:.4g} W, "
                f"P_mech {p_mech[k]:.4g} W): the drive would make energy")
        ratio = np.abs(p_elec) / np.maximum(nominal, np.abs(p_mech))
        k = int(np.argmax(ratio))
        if ratio[k] > MAGNITUDE_FACTOR:
            problems.append(
                f"{q} quadrant: |P_elec| = {abs(p_elec[k]):.4g} W at {speed[k]:.4g} rpm, "
                f"{torque[k]:.4g} N m is {ratio[k]:.3g} times the larger of the nominal "
                f"power ({nominal:.4g} W) and P_mech: implausible for this drive")
        spread.append(p_elec)
    if spread and not problems:
        values = np.concatenate(spread)
        if math.isclose(float(np.ptp(values)), 0.0, abs_tol=MIN_SPREAD * nominal):
            problems.append(f"P_elec is {values[0]:.4g} W everywhere in the domain: "
                            "it does not depend on speed and torque")
    return problems


def check_physics(model: PowerModel, path: str | Path | None,
                  limits: tuple[float, float] | None = None) -> None:
    """Raise an InputError naming ``path`` when :func:`physics_problems` finds any."""
    problems = physics_problems(model, limits)
    if problems:
        raise InputError(path, "physically impossible power model: " + "; ".join(problems),
                         expected="losses P_elec - P_mech >= 0 and a plausible magnitude "
                                  "over the model's domain (bench fit writes such a model)")
