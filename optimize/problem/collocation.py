"""Radau IIA collocation coefficients on the unit interval."""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass(frozen=True)
class Collocation:
    """Coefficients of degree-``d`` Radau collocation on ``[0, 1]``.

    Attributes
    ----------
    tau : ndarray (d + 1,)
        ``0`` followed by the ``d`` Radau points (the last one is ``1``).
    deriv : ndarray (d + 1, d)
        ``deriv[r, j]`` is the derivative at ``tau[j + 1]`` of the Lagrange
        polynomial through all ``d + 1`` points that is one at ``tau[r]``.
    quad : ndarray (d,)
        Quadrature weights of the ``d`` Radau points (they sum to one; exact
        for polynomials up to degree ``2 d - 2``).
    """

    degree: int
    tau: np.ndarray
    deriv: np.ndarray
    quad: np.ndarray


def radau(degree: int) -> Collocation:
    """Radau collocation coefficients of the given degree (1 to 9)."""
    if not 1 <= degree <= 9:
        raise ValueError(f"collocation degree must be in 1..9, got {degree}")
    tau = np.array([0.0] + list(ca.collocation_points(degree, "radau")))
    deriv = np.zeros((degree + 1, degree))
    for r in range(degree + 1):
        others = np.delete(tau, r)
        poly = np.poly1d(others, r=True) / np.prod(tau[r] - others)
        deriv[r, :] = np.polyder(poly)(tau[1:])
    quad = np.zeros(degree)
    pts = tau[1:]
    for j in range(degree):
        others = np.delete(pts, j)
        poly = np.poly1d(others, r=True) / np.prod(pts[j] - others)
        quad[j] = np.polyint(poly)(1.0) - np.polyint(poly)(0.0)
    return Collocation(degree=degree, tau=tau, deriv=deriv, quad=quad)
