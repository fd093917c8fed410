"""A start point of an OCP made of parts: each part fills the variables it owns.

A start comes as the variables some parts have (a stored solution of the kite, the
circular loop of the homotopy: the kite's part's own guess); :func:`fill` asks every
other part, in the formulation's order, for its variables
(:meth:`optimize.problem.part.Part.guess`), handing it the quantities of the parts
before it along the start trajectory. So a stored start keeps working when a part is
added, and a part's start is part of the part.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from optimize.problem.formulation import VARIABLE_VECTORS
from optimize.problem.ocp import Ocp, grid_times
from optimize.problem.part import StartPoint

#: the key of each vector of variables in a start's arrays (:meth:`optimize.problem.ocp.Ocp.pack`)
KEYS = {"states": "x", "controls": "u", "algebraic": "z", "fictitious": "fict"}


def fill(ocp: Ocp, arrays: dict[str, np.ndarray], period_s: float,
         parameters: Mapping[str, float], known: set[str]) -> dict[str, np.ndarray]:
    """``arrays`` (physical ``x (NX, N d + 1)``, ``u (NU, N)``, ``z (NZ, N d)``,
    ``fict (NF, N d)``) with the variables not in ``known`` filled by their parts.

    Parameters
    ----------
    ocp : Ocp
    arrays : dict of ndarray
        The start, by :data:`KEYS` (a variable not known may hold anything).
    period_s : float
        The start's period [s].
    parameters : dict of float
        The model's parameters by name (the scenario's, :attr:`Scenario.parameters`).
    known : set of str
        The variables ``arrays`` holds.
    """
    form = ocp.formulation
    out = {key: np.array(a, dtype=float) for key, a in arrays.items()}
    known = set(known)
    times, d = grid_times(ocp, period_s), ocp.coll.degree
    for k, part in enumerate(getattr(form, "parts", ())):
        own = {n for group in VARIABLE_VECTORS for n in getattr(part, group).names}
        if own <= known:
            continue
        fn, names = form.prefix_quantities(k)
        x, u, z = out["x"][:, 1:], np.repeat(out["u"], d, axis=1), out["z"]
        par = [float(parameters[name]) for name in form.parameters]
        values = np.asarray(fn.map(x.shape[1])(x, u, z, par))
        start = StartPoint(times, period_s, ocp.n_intervals, parameters,
                           dict(zip(names, values, strict=True)))
        guess = part.guess(start)
        for group, key in KEYS.items():
            variables = getattr(ocp.dae, group)
            for name in getattr(part, group).names:
                out[key][variables.index(name)] = guess.get(name, 0.0)
        known |= own
    return out


def part_start(ocp: Ocp, period_s: float, parameters: Mapping[str, float]
               ) -> dict[str, np.ndarray]:
    """A start of every part from its own guess alone (the homotopy's: the kite's
    circular loop at ``period_s``, then the others along it)."""
    n, n_coll = ocp.n_intervals, ocp.layout.n_coll
    dae = ocp.dae
    zeros = {"x": np.zeros((dae.states.size, n_coll + 1)),
             "u": np.zeros((dae.controls.size, n)),
             "z": np.zeros((dae.algebraic.size, n_coll)),
             "fict": np.zeros((dae.fictitious.size, n_coll))}
    return fill(ocp, zeros, period_s, parameters, set())
