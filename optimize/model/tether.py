"""The tether as a straight rod with mass, and its drag over elements (awebox's models).

A straight line from the winch (the origin) to the kite at ``r`` [m], NED, moving
with the kite at velocity ``v`` [m/s]. Both models follow awebox (awebox/awebox at
commit 03adf950):

* **Mass** (``awebox/mdl/lagr_dyn_dir/energy.py`` ``add_node_kinetic`` and
  ``add_node_potential``, ``lagr_dyn.py`` ``momentum_correction``): the line's mass
  ``m = mu |r|`` with ``mu`` its mass per length; its velocity is linear along it
  from ``v_0 = (v . e) e`` at the winch (the reeling speed along the unit vector
  ``e = r / |r|``) to ``v`` at the kite, so its kinetic energy is
  ``T = m / 6 (|v_0|^2 + v_0 . v + |v|^2)``; its potential energy is its weight at
  half the kite's height above the winch, ``V = m g h / 2``. The line's mass
  changes as it is reeled: the mass flow ``dm/dt = mu (r . v) / |r|`` carries the
  momentum ``dm/dt v`` (awebox's correction for an open system). The kite's
  equation of motion gains :func:`rod_residual`,
  ``d/dt dT/dv - dT/dr + dV/dr - dm/dt v``.
* **Drag** (``awebox/mdl/aero/tether_dir/element.py`` ``get_element_drag_fun`` and
  ``segment.py`` ``get_distributed_segment_forces``, the ``multi`` model): ``n``
  equal elements; element ``k`` at ``s_k = (k + 1/2) / n`` of the way up moves at
  ``s_k v`` and sees the wind at its height, the apparent wind ``u = w(s_k r) -
  s_k v``; its drag is ``C_D,t 1/2 rho |u| d L_perp u`` with ``L_perp`` the part of
  its length ``|r| / n`` across ``u``; the kite takes the fraction ``s_k`` of it
  (the winch the rest). In still air with the line across its motion the sum
  tends to ``C_D,t 1/2 rho d |r| |v| v / 4``: the quarter of the line's drag of the
  lumped model.

Pure functions of CasADi expressions (``SX``) or numbers (``DM``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca

from optimize.model.aero import altitude_above_ground, wind_speed
from optimize.model.atmosphere import air_density
from optimize.model.params import KiteParams, TetherModel, WindModel

#: the line's force on the kite, NED [N]: the tether part's algebraic variables
LINE_FORCE = ("f_line_x_n", "f_line_y_n", "f_line_z_n")

#: smoothing of the apparent wind's norm and of the length across it [m/s], [m]: keeps
#: their derivatives finite where either vanishes (awebox smooths by 1e-6 likewise)
_EPS = 1e-6


def rod_energies(r: Any, v: Any, mass_kg_m: float, g_m_s2: float) -> tuple[Any, Any]:
    """Kinetic and potential energy [J] of the straight line from the winch to ``r``.

    Parameters
    ----------
    r, v : 3-vector
        The line's top (the kite) and its velocity, NED [m], [m/s].
    mass_kg_m : float
        Mass per length [kg/m].
    g_m_s2 : float
        Gravitational acceleration [m/s^2].

    Returns
    -------
    kinetic, potential : scalar
        ``T`` and ``V`` (the potential zero at the winch's height).
    """
    length = ca.norm_2(r)
    e = r / length
    v0 = ca.dot(v, e) * e
    mass = mass_kg_m * length
    kinetic = mass / 6.0 * (ca.dot(v0, v0) + ca.dot(v0, v) + ca.dot(v, v))
    potential = mass * g_m_s2 * (-r[2]) / 2.0
    return kinetic, potential


def rod_residual(r: Any, v: Any, a: Any, mass_kg_m: float, g_m_s2: float) -> Any:
    """The line's terms of the kite's equation of motion [N] (added to ``m a - F``).

    ``d/dt dT/dv - dT/dr + dV/dr - dm/dt v`` with the energies of :func:`rod_energies`
    and the mass flow ``dm/dt = mass_kg_m (r . v) / |r|``, at acceleration ``a``
    [m/s^2]; Lagrange's equations of the open system as awebox writes them.
    """
    rs, vs, acc = ca.SX.sym("r", 3), ca.SX.sym("v", 3), ca.SX.sym("a", 3)
    kinetic, potential = rod_energies(rs, vs, mass_kg_m, g_m_s2)
    momentum = ca.gradient(kinetic, vs)
    momentum_rate = ca.jtimes(momentum, rs, vs) + ca.jtimes(momentum, vs, acc)
    mass_flow = mass_kg_m * ca.dot(rs, vs) / ca.norm_2(rs)
    residual = (momentum_rate - ca.gradient(kinetic, rs) + ca.gradient(potential, rs)
                - mass_flow * vs)
    return ca.Function("rod_residual", [rs, vs, acc], [residual])(r, v, a)


def element_drag(r: Any, v: Any, wind_at: Callable[[Any], Any],
                 density_at: Callable[[Any], Any], cd_diameter_m: float,
                 n_elements: int) -> Any:
    """The line's drag the kite takes [N], NED, summed over ``n_elements`` elements.

    Parameters
    ----------
    r, v : 3-vector
        The kite's position [m] and velocity [m/s], NED.
    wind_at, density_at : callable
        Wind velocity (3-vector [m/s]) and air density [kg/m^3] at a point ``p`` of
        the line (NED [m]).
    cd_diameter_m : float
        The line's drag coefficient times its diameter [m].
    n_elements : int
        Number of equal elements (midpoint rule).
    """
    length = ca.norm_2(r)
    force = 0
    for k in range(n_elements):
        s = (k + 0.5) / n_elements
        u = wind_at(s * r) - s * v
        speed = ca.sqrt(ca.dot(u, u) + _EPS**2)
        along = ca.dot(r, u) / (speed * n_elements)  # element's length along u
        across = ca.sqrt((length / n_elements) ** 2 - along**2 + _EPS**2)
        force = force + s * cd_diameter_m * 0.5 * density_at(s * r) * speed * across * u
    return force


def line_force(r: Any, v: Any, a: Any, wind_speed_m_s: Any, kite: KiteParams, wind: WindModel,
               tether: TetherModel) -> Any:
    """The force the line puts on the kite [N], NED: minus :func:`rod_residual` (its
    mass) plus :func:`element_drag` (its drag over elements), each when ``tether`` has
    it; 0 for a massless line with the lumped drag.

    Parameters
    ----------
    r, v, a : 3-vector
        The kite's position [m], velocity [m/s] and acceleration [m/s^2], NED.
    wind_speed_m_s : scalar
        The reference wind speed [m/s] of ``wind``'s profile (along +x).
    kite : KiteParams
        Gravity, and the density at the ground.
    wind : WindModel
        The profile, the winch's height and the atmosphere's lapse rate.
    tether : TetherModel
    """
    force = ca.DM.zeros(3)
    if tether.mass_kg_m > 0:
        force = force - rod_residual(r, v, a, tether.mass_kg_m, kite.g_m_s2)
    if tether.drag_elements > 0:
        def wind_at(p):
            return ca.vertcat(wind_speed(altitude_above_ground(p, wind), wind_speed_m_s, wind),
                              0, 0)

        def density_at(p):
            return air_density(altitude_above_ground(p, wind), kite.rho_kg_m3, kite.g_m_s2,
                               wind.temperature_lapse_k_m)

        force = force + element_drag(r, v, wind_at, density_at,
                                     tether.drag_coefficient * tether.diameter_m,
                                     tether.drag_elements)
    return force
