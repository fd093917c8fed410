"""A synthetic winding behind an RC ladder of nodes: the temperature a sensor would log.

The truth of a drive whose winding is more than one thermal node (the winding, the
stator iron and housing, ...): each node ``k`` a heat capacity ``c_k`` [J/K] joined to
the next by a resistance ``r_k`` [K/W], the last to the ambient, the heat entering at
the winding::

    c_k dtheta_k/dt = q_k - (theta_k - theta_(k+1)) / r_k,   q_0 = q,
    q_k = (theta_(k-1) - theta_k) / r_(k-1)

Integrated exactly (matrix exponentials) for a heat held over each step, in node
form, independently of the mode sums the fit uses (:mod:`fitting.thermal_network`).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm


def ladder_matrices(ladder) -> tuple[np.ndarray, np.ndarray]:
    """``A``, ``b`` of the nodes' rises over the ambient, ``dx/dt = A x + b q``.

    Parameters
    ----------
    ladder : sequence of (float, float)
        Per node from the winding: heat capacity [J/K] and resistance to the next
        node (the last: to the ambient) [K/W].
    """
    n = len(ladder)
    a = np.zeros((n, n))
    for k, (c, r) in enumerate(ladder):
        a[k, k] -= 1.0 / (r * c)
        if k + 1 < n:
            c_next = ladder[k + 1][0]
            a[k, k + 1] += 1.0 / (r * c)
            a[k + 1, k + 1] -= 1.0 / (r * c_next)
            a[k + 1, k] += 1.0 / (r * c_next)
    b = np.zeros(n)
    b[0] = 1.0 / ladder[0][0]
    return a, b


def winding_bin_means(ladder, heat_w: np.ndarray, bin_s: float, substeps: int = 10
                      ) -> np.ndarray:
    """The winding's rise over the ambient [K] averaged over each bin of ``bin_s`` [s],
    the heat [W] held per bin, every node at the ambient at the start (trapezoidal
    mean of ``substeps`` exact sub-steps per bin)."""
    a, b = ladder_matrices(ladder)
    e = expm(a * bin_s / substeps)
    gain = np.linalg.solve(a, (e - np.eye(len(ladder))) @ b)
    x = np.zeros(len(ladder))
    means = np.zeros(len(heat_w))
    for k, q in enumerate(heat_w):
        acc = 0.5 * x[0]
        for j in range(substeps):
            x = e @ x + gain * q
            acc += x[0] * (0.5 if j == substeps - 1 else 1.0)
        means[k] = acc / substeps
    return means


def heat_steps(rng: np.random.Generator, n_bins: int, max_w: float = 1500.0
               ) -> np.ndarray:
    """A bench session's heat per bin: steps held 12-60 bins, uniform in [0, max_w] W."""
    return np.repeat(rng.uniform(0, max_w, n_bins), rng.integers(12, 60, n_bins))[:n_bins]
