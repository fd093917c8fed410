"""The four scenario kinds of a sweep: which average power is maximized and whether
the drive limits apply (the paper's four curves of Fig. 8).

Every stage names a kind by its key (``"elec-lim"``); the key is what
``summary.parquet``, ``aep.json`` and ``sizing.json`` carry in their ``kind``
column (docs/schemas.md).
"""

from __future__ import annotations

from typing import NamedTuple


class Kind(NamedTuple):
    """A scenario kind.

    Attributes
    ----------
    objective : str
        ``"electrical"`` or ``"mechanical"``: the cycle-average power maximized.
    drive_limits : bool
        Whether the drive's speed, torque and power limits apply.
    """

    objective: str
    drive_limits: bool


#: kind key -> (objective, drive limits on), in the paper's order
KINDS: dict[str, Kind] = {
    "elec-lim": Kind("electrical", True),
    "elec-free": Kind("electrical", False),
    "mech-lim": Kind("mechanical", True),
    "mech-free": Kind("mechanical", False),
}
#: kind key -> label in tables and figure legends
LABELS: dict[str, str] = {
    "elec-lim": "elec. optimized, constrained",
    "elec-free": "elec. optimized, unconstrained",
    "mech-lim": "mech. optimized, constrained",
    "mech-free": "mech. optimized, unconstrained",
}
#: the kinds ``bench optimize`` solves unless told otherwise (comma list)
DEFAULT_KINDS = ",".join(KINDS)
