"""The drive power model as a CasADi expression (for the optimal control problem)."""

from __future__ import annotations

from typing import Any

import casadi as ca

from fitting.terms import powers


def evaluate(terms, coefs, speed, torque) -> Any:
    """``sum_k c_k speed**i_k torque**j_k`` for SX, MX, DM or plain floats.

    Each power of speed and torque is built once by repeated multiplication.
    """
    sp = powers(speed, max(i for i, _ in terms), None)
    tq = powers(torque, max(j for _, j in terms), None)
    total = 0
    for (i, j), c in zip(terms, coefs, strict=True):
        factors = [f for f in (sp[i], tq[j]) if f is not None]
        term = c
        for f in factors:
            term = term * f
        total = total + term
    if isinstance(total, (int, float)):
        return ca.DM(total)
    return total
