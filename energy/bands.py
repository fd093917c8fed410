"""Confidence bands of the optimal power from the power model's coefficient covariance.

For a power model ``P_elec(n, T) = sum_k a_k phi_k(n, T)`` (``phi_k = n^i T^j``,
any term set the model file declares), the optimal cycle-average electrical
power ``P*(a) = min over cycles of mean_t P_elec`` has, by the envelope theorem,
the gradient

    dP*/da_k = mean over the cycle of phi_k(n(t), T(t))

along the optimal trajectory: the cycle's own change does not contribute to
first order. So ``sigma_P^2 = g^T Sigma g`` with ``g`` the cycle-time averages
of the basis terms (:func:`basis_averages`), no re-solve needed; the model gives its
value and uncertainty there (:meth:`fitting.power_model.PowerModel.of_basis`,
:meth:`~fitting.power_model.PowerModel.sigma_of_basis`). For a cycle optimized for the
*mechanical* objective the trajectory does not depend on ``a`` at all, and the
same formula is exact. (The OCP also carries a control regularization of about
0.1 W; its derivative is neglected.)

Because every wind speed shares the same coefficients, the errors are fully
correlated along the curve: the AEP's gradient is ``G = sum_i (dAEP/dP_i) g_i``
and ``sigma_AEP^2 = G^T Sigma G``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from optimize.door import cycle_quadrature

#: two-sided 95 % normal quantile
Z95 = 1.959963984540054


def basis_averages(trajectory: pd.DataFrame, model: Any) -> np.ndarray:
    """Cycle-time averages of the power model's basis functions
    (:meth:`fitting.power_model.PowerModel.basis`).

    Parameters
    ----------
    trajectory : DataFrame
        One scenario's rows of ``trajectories.parquet``: ``weight`` (quadrature
        weights summing to 1), ``speed_rpm``, ``torque_nm``.
    model : fitting.power_model.PowerModel
        The power model.

    Returns
    -------
    ndarray (n_terms,)
        ``g_k`` in the units of the model's ``rpm`` coefficient set [rpm^i N m^j].
    """
    w = trajectory["weight"].to_numpy(float)
    if abs(w.sum() - 1.0) > 1e-6:
        raise ValueError(f"quadrature weights sum to {w.sum():.8f}, not 1")
    n = trajectory["speed_rpm"].to_numpy(float)
    t = trajectory["torque_nm"].to_numpy(float)
    return np.array([cycle_quadrature(w, b) for b in model.basis(n, t)])


def curve_gradients(trajectories: pd.DataFrame, scenarios: Sequence[str], model: Any,
                    known: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
    """``g`` for each scenario of a curve, shape ``(n_scenarios, n_terms)``.

    ``known`` gives ``g`` of scenarios with no trajectory in ``trajectories`` (the
    points added by ``bench aep --refine``, whose averages were taken at solve time).
    """
    known = known or {}
    groups = dict(tuple(trajectories.groupby("scenario", sort=False)))
    missing = [s for s in scenarios if s not in groups and s not in known]
    if missing:
        raise KeyError(f"no trajectory for scenarios {missing}")
    return np.array([np.asarray(known[s], float) if s in known
                     else basis_averages(groups[s], model) for s in scenarios])
