"""The tether's mass and distributed drag as a part of the cycle OCP.

The part has three algebraic variables, the line's force on the kite
(:data:`optimize.model.tether.LINE_FORCE`, NED [N]), and one residual row per
component: the variable equals :func:`optimize.model.tether.line_force` at the kite's
position, velocity and acceleration (the rod's Lagrange terms and the element drag,
awebox's models). The part puts it on the kite through the external-force quantities
(:data:`optimize.problem.kite_part.EXTERNAL`) the kite's Newton rows take, as awebox
carries its tether forces in algebraic variables (``f_tether``) of their own. It joins
the kite's parts only when the system file gives the line a mass or element drag
(:func:`optimize.problem.parts.kite_parts`): the paper's massless line with the
lumped drag has no part.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from kernel.names import WIND_SPEED
from optimize.model.kite_model import KiteDae
from optimize.model.tether import LINE_FORCE, line_force
from optimize.model.variables import Variables
from optimize.problem.kite_part import EXTERNAL
from optimize.problem.part import Part, StartPoint

#: the kite's position, velocity and acceleration, NED
_R, _V, _A = (tuple(f"{p}_{a}_{u}" for a in "xyz") for p, u in
              (("r", "m"), ("v", "m_s"), ("a", "m_s2")))


@dataclass(frozen=True)
class TetherPart(Part):
    """The line's mass and drag (a :class:`optimize.problem.part.Part`).

    Parameters
    ----------
    dae : KiteDae
        The kite's model: its parameters, wind profile and tether model.
    force_scale_n : float
        Typical force [N] the residual rows and the variables are divided by (the
        kite's force scale).
    """

    dae: KiteDae
    force_scale_n: float
    name: str = "tether"
    algebraic: Variables = Variables(LINE_FORCE)

    def _force(self, r: Any, v: Any, a: Any, wind_speed_m_s: Any) -> Any:
        d = self.dae
        return line_force(r, v, a, wind_speed_m_s, d.kite, d.wind, d.tether)

    def quantities(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """The line's force added to the forces other parts put on the kite
        (:data:`optimize.problem.kite_part.EXTERNAL`)."""
        return {ext: q.get(ext, 0) + q[own] for ext, own in zip(EXTERNAL[:3], LINE_FORCE,
                                                               strict=True)}

    def residual(self, q: Mapping[str, Any]) -> list[Any]:
        """The variables minus the line's force at the kite's motion, over the scale."""
        def vec(names):
            return ca.vertcat(*[q[n] for n in names])

        force = self._force(vec(_R), vec(_V), vec(_A), q[WIND_SPEED])
        return [(vec(LINE_FORCE) - force) / self.force_scale_n]

    def scales(self) -> dict[str, float]:
        """The kite's force scale each."""
        return dict.fromkeys(LINE_FORCE, self.force_scale_n)

    def guess(self, start: StartPoint) -> dict[str, np.ndarray]:
        """The line's force along the start trajectory (at its Radau points)."""
        r, v, a = (ca.SX.sym(n, 3) for n in "rva")
        force = self._force(r, v, a, start.parameters[WIND_SPEED])
        fn = ca.Function("line_force", [r, v, a], [force])
        q = start.quantities

        def rows(names):
            return np.vstack([np.asarray(q[n], dtype=float) for n in names])

        values = np.asarray(fn.map(rows(_R).shape[1])(rows(_R), rows(_V), rows(_A)))
        return dict(zip(LINE_FORCE, values, strict=True))
