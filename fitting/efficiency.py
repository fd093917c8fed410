"""Drive efficiency (paper eqs. 1 and 2), its masking rules, and what the map shows.

Motor quadrant (the drive delivers shaft power, P_mech > 0)::

    eta_mot = P_mech / P_elec                       # paper eq. (1)

Generator quadrant (P_mech <= 0)::

    eta_gen = (-P_elec) / (-P_mech)                 # paper eq. (2)

The map (:mod:`fitting.efficiency_map`) shows an efficiency by these equations and the
masking rules, at most the quadrant's ceiling (:func:`shown_efficiency`); a point's
uncertainty is in :mod:`fitting.point_uncertainty`, the sessions' repeatability in
:mod:`fitting.repeatability`, the map's honesty towards the points in
:mod:`fitting.map_honesty`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from fitting.domain import BAND_FRAC

#: Status of a map node or point after the masking rules.
OK, NEAR_AXIS, NEGATIVE, ABOVE_MAX, OUTSIDE_DOMAIN, CLIPPED = (
    "ok", "near_axis", "negative", "above_max", "outside_domain", "clipped"
)


#: Efficiency band edges for the area shares (the last band includes 1.0).
BAND_EDGES = (0.0, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 1.0)


@dataclass(frozen=True)
class MaskingRules:
    """How efficiencies that would distort the map are masked (paper section III-B.3).

    Parameters
    ----------
    nominal_power_w : float
        Nominal power of the drive [W] (the campaign's drive rating).
    mech_frac : float
        Mask points with ``|P_mech| < mech_frac * nominal_power_w`` (near the axes the
        efficiency divides by a small number) [-].
    elec_frac : float
        Mask points with ``|P_elec| < elec_frac * nominal_power_w`` [-].
    max_efficiency : float
        Efficiencies above this are masked: a drive cannot exceed 1, so such a
        value is a measurement artefact [-].
    envelope_band_frac : float
        Speed band width of the measured envelope (:mod:`fitting.domain`), a
        fraction of the quadrant's largest |speed| [-].
    accuracy_frac : float
        Standard uncertainty of one averaged power reading from the instruments'
        accuracy, a fraction of the reading [-] (a power analyzer's and a torque
        flange's accuracy class are 0.05-0.1 % of reading, speed adds less; 0.2 %
        also covers a table's printed resolution and calibration drift). It is the
        floor of each point's uncertainty
        (:func:`fitting.point_uncertainty.point_uncertainty`), which sets
        the map's ceiling.

    Notes
    -----
    Negative efficiencies (the drive draws power while it is driven, or feeds the
    grid while it drives the shaft) are set to 0, as the paper does; masked
    (near-axis, above-max) values become NaN. Both are drawn white.
    """

    nominal_power_w: float
    mech_frac: float = 0.02
    elec_frac: float = 0.02
    max_efficiency: float = 1.0
    envelope_band_frac: float = BAND_FRAC
    accuracy_frac: float = 0.002

    def __post_init__(self) -> None:
        for name in ("mech_frac", "elec_frac"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v < 1.0):
                raise ValueError(f"{name} = {v!r}: a fraction in [0, 1) expected")
        if not (np.isfinite(self.nominal_power_w) and self.nominal_power_w > 0):
            raise ValueError("nominal_power_w must be a positive power [W]")
        if not self.max_efficiency > 0:
            raise ValueError("max_efficiency must be positive")
        if not (np.isfinite(self.accuracy_frac) and 0.0 <= self.accuracy_frac < 0.5):
            raise ValueError(f"accuracy_frac = {self.accuracy_frac!r}: a fraction in [0, 0.5) "
                             "expected")
        if not (np.isfinite(self.envelope_band_frac) and 0.0 < self.envelope_band_frac <= 0.5):
            raise ValueError(f"envelope_band_frac = {self.envelope_band_frac!r}: "
                             "a fraction in (0, 0.5] expected")

    def to_dict(self) -> dict:
        """Settings plus a one-line statement of each rule (written into the outputs)."""
        d = asdict(self)
        d["rules"] = [
            f"|P_mech| < {self.mech_frac:g} * {self.nominal_power_w:g} W -> masked (NaN)",
            f"|P_elec| < {self.elec_frac:g} * {self.nominal_power_w:g} W -> masked (NaN)",
            "negative efficiency -> 0, drawn white as the masked nodes",
            f"efficiency > {self.max_efficiency:g} -> masked (NaN)",
            "grid nodes outside the quadrant's measured envelope (highest and lowest measured "
            f"torque per speed band of {self.envelope_band_frac:g} x max |speed|) -> NaN "
            "(no extrapolation)",
            "map: the loss P_elec - P_mech is interpolated linearly between measured points "
            "and eta derived from it",
            "map: eta above the quadrant's highest measured eta + that point's uncertainty "
            "-> clipped to that ceiling (status 'clipped'); every accepted point counts; a "
            "point's power uncertainty is the standard error of its window mean (std / "
            f"sqrt(n_samples)) and {self.accuracy_frac:g} of the reading (instrument "
            "accuracy) in quadrature, and its loss the campaign's pooled loss repeatability; "
            "grid nodes are moved where a bilinear reading would miss a point by more than "
            "its uncertainty",
        ]
        return d


def raw_efficiency(p_mech_w, p_elec_w) -> np.ndarray:
    """Efficiency by paper eqs. (1) and (2), without masking (inf/NaN where dividing by 0)."""
    p_mech = np.asarray(p_mech_w, dtype=float)
    p_elec = np.asarray(p_elec_w, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p_mech > 0, p_mech / p_elec, (-p_elec) / (-p_mech))


def masked_efficiency(p_mech_w, p_elec_w, rules: MaskingRules) -> tuple[np.ndarray, np.ndarray]:
    """Efficiency with the masking rules applied.

    Parameters
    ----------
    p_mech_w, p_elec_w : array_like
        Mechanical and electrical power [W] (sign convention of docs/schemas.md).
    rules : MaskingRules

    Returns
    -------
    eta : numpy.ndarray
        Efficiency [-]: 0 where negative, NaN where masked.
    status : numpy.ndarray of str
        ``ok``, ``near_axis``, ``negative`` or ``above_max`` per point.
    """
    p_mech = np.asarray(p_mech_w, dtype=float)
    p_elec = np.asarray(p_elec_w, dtype=float)
    eta = raw_efficiency(p_mech, p_elec)
    near = (np.abs(p_mech) < rules.mech_frac * rules.nominal_power_w) | (
        np.abs(p_elec) < rules.elec_frac * rules.nominal_power_w
    )
    status = np.full(eta.shape, OK, dtype=object)
    negative = ~near & (eta < 0)
    above = ~near & ~negative & (eta > rules.max_efficiency)
    status[near] = NEAR_AXIS
    status[negative] = NEGATIVE
    status[above] = ABOVE_MAX
    eta = np.where(negative, 0.0, eta)
    eta = np.where(near | above, np.nan, eta)
    return eta, status


def shown_efficiency(p_mech, quadrant, loss, rules: MaskingRules, ceilings: dict):
    """Efficiency and status the map shows for a loss at an exact ``p_mech`` (eqs. 1-2,
    masking rules, NaN loss ``outside_domain``, above the ceiling ``clipped``)."""
    eta, status = masked_efficiency(p_mech, p_mech + loss, rules)
    status[~np.isfinite(loss)] = OUTSIDE_DOMAIN
    for q, ceiling in ceilings.items():
        over = (quadrant == q) & (status == OK) & (eta > ceiling["eta"])
        eta[over] = ceiling["eta"]
        status[over] = CLIPPED
    return eta, status
