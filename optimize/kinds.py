"""The scenario kinds of a sweep: which cycle average is maximized and whether the
drive limits apply (the paper's four curves of Fig. 8).

Every stage names a kind by its key (``"elec-lim"``); the key is what
``summary.parquet``, ``aep.json`` and ``sizing.json`` carry in their ``kind``
column (docs/schemas.md). A kind owns its objective: the cycle average the OCP
minimizes (average power drawn, so generation is maximized), the summary column
that holds it, and its label in tables and figures.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Objective:
    """A cycle-average power an optimization can maximize.

    Attributes
    ----------
    name : str
        ``"electrical"`` or ``"mechanical"``.
    short : str
        Its prefix in kind keys (``"elec"``, ``"mech"``).
    average : str
        The OCP's cycle average it minimizes (power drawn [W], negative = generated).
    summary_column : str
        The column of ``summary.parquet`` holding that average [W].
    """

    name: str
    short: str
    average: str
    summary_column: str


#: objective name -> objective
OBJECTIVES: dict[str, Objective] = {
    "electrical": Objective("electrical", "elec", "p_elec_w", "avg_p_elec_w"),
    "mechanical": Objective("mechanical", "mech", "p_mech_w", "avg_p_mech_w"),
}


@dataclass(frozen=True)
class Kind:
    """A scenario kind.

    Attributes
    ----------
    key : str
        ``"<objective short>-lim"`` or ``"-free"``, e.g. ``"elec-lim"``.
    objective : str
        ``"electrical"`` or ``"mechanical"``: the cycle-average power maximized.
    drive_limits : bool
        Whether the drive's speed, torque and power limits apply.
    label : str
        Label in tables and figure legends.
    """

    key: str
    objective: str
    drive_limits: bool
    label: str

    @property
    def goal(self) -> Objective:
        """The objective this kind maximizes."""
        return OBJECTIVES[self.objective]

    @property
    def weights(self) -> dict[str, float]:
        """Objective weights by cycle-average name (the OCP minimizes their sum)."""
        return {self.goal.average: 1.0}

    @property
    def summary_column(self) -> str:
        """The summary column of the average this kind maximizes [W]."""
        return self.goal.summary_column


def _kind(objective: str, drive_limits: bool) -> Kind:
    short = OBJECTIVES[objective].short
    key = f"{short}-{'lim' if drive_limits else 'free'}"
    label = (f"{short}. optimized, "
             f"{'constrained' if drive_limits else 'unconstrained'}")
    return Kind(key, objective, drive_limits, label)


#: kind key -> kind, in the paper's order
KINDS: dict[str, Kind] = {k.key: k for k in (
    _kind("electrical", True), _kind("electrical", False),
    _kind("mechanical", True), _kind("mechanical", False))}
#: kind key -> label in tables and figure legends
LABELS: dict[str, str] = {key: kind.label for key, kind in KINDS.items()}
#: the kinds ``bench optimize`` solves unless told otherwise (comma list)
DEFAULT_KINDS = ",".join(KINDS)


def kind_of(objective: str, drive_limits: bool) -> Kind:
    """The kind of an objective name and a drive-limits switch."""
    for kind in KINDS.values():
        if kind.objective == objective and kind.drive_limits == drive_limits:
            return kind
    raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")

