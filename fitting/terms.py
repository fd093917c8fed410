"""Term lists of the polynomial power models (paper eq. 4 and its generalisations).

A term ``(i, j)`` is ``speed**i * torque**j`` (docs/schemas.md §3).
"""

from __future__ import annotations

from typing import Any

#: The paper's eq. (4): P_elec = a0 + a1 w^2 + a2 T^2 + a3 w T (docs/paper_figures.md §1).
PAPER_TERMS: tuple[tuple[int, int], ...] = ((0, 0), (2, 0), (0, 2), (1, 1))

#: The paper's higher-order check space: "terms up to T^4 and w^6" (section III-C),
#: read as every speed exponent 0..6 combined with every torque exponent 0..4.
PAPER_SPACE_MAX_SPEED_EXP = 6
PAPER_SPACE_MAX_TORQUE_EXP = 4

MIN_ORDER = 1
MAX_ORDER = 6


def full_polynomial(order: int) -> tuple[tuple[int, int], ...]:
    """All terms ``speed**i * torque**j`` with ``i + j <= order``.

    Ordered by total degree, then by falling speed exponent:
    ``(0,0), (1,0), (0,1), (2,0), (1,1), (0,2), ...``.

    Parameters
    ----------
    order : int
        Total polynomial order, ``MIN_ORDER..MAX_ORDER``.
    """
    if not MIN_ORDER <= order <= MAX_ORDER:
        raise ValueError(f"order {order} outside {MIN_ORDER}..{MAX_ORDER}")
    return tuple((d - j, j) for d in range(order + 1) for j in range(d + 1))


def paper_space() -> tuple[tuple[int, int], ...]:
    """The paper's check space: ``speed**i * torque**j`` for i <= 6 and j <= 4 (35 terms)."""
    return tuple(
        sorted(
            (
                (i, j)
                for i in range(PAPER_SPACE_MAX_SPEED_EXP + 1)
                for j in range(PAPER_SPACE_MAX_TORQUE_EXP + 1)
            ),
            key=lambda t: (t[0] + t[1], -t[0]),
        )
    )


def term_label(term: tuple[int, int]) -> str:
    """Readable label of a term, e.g. ``(2, 1)`` -> ``"w^2*T"``, ``(0, 0)`` -> ``"1"``."""
    parts = []
    for sym, e in (("w", term[0]), ("T", term[1])):
        if e == 1:
            parts.append(sym)
        elif e > 1:
            parts.append(f"{sym}^{e}")
    return "*".join(parts) if parts else "1"


def powers(x: Any, n: int, one: Any) -> list:
    """``[one, x, x**2, ..., x**n]``, each power by one multiplication (floats, arrays or
    CasADi expressions alike)."""
    out = [one]
    for _ in range(n):
        out.append(x if len(out) == 1 else out[-1] * x)
    return out
