"""Drive efficiency (paper eqs. 1 and 2), its masking rules, and the gridded map (Fig. 5).

Motor quadrant (the drive delivers shaft power, P_mech > 0)::

    eta_mot = P_mech / P_elec                       # paper eq. (1)

Generator quadrant (P_mech <= 0)::

    eta_gen = (-P_elec) / (-P_mech)                 # paper eq. (2)

The map never invents efficiency: it is drawn only inside each quadrant's
measured envelope (:mod:`fitting.domain`), it interpolates the measured *loss*
``P_elec - P_mech`` (smooth, and small against the powers) rather than
``P_elec``, and no node shows an efficiency above the quadrant's highest
measured efficiency plus that point's own uncertainty (such nodes are clipped to
the ceiling and flagged ``clipped``). Every accepted point counts for the
ceiling, so the ceiling is never below a measured point. A point's uncertainty
(:func:`point_uncertainty`) holds its window statistics, the instruments'
accuracy and how well the campaign's sessions repeat an operating point
(:func:`loss_repeatability`); the map's grid, read bilinearly as a user reads it
(:func:`read_grid`), shows every accepted point within it (:func:`honour_points`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from scipy.spatial import ConvexHull, Delaunay, QhullError

from fitting.domain import BAND_FRAC, in_polygon, quadrant_envelopes
from fitting.points import QUADRANTS, quadrant_of
from kernel.units import RPM_PER_RAD_S

#: Status of a map node or point after the masking rules.
OK, NEAR_AXIS, NEGATIVE, ABOVE_MAX, OUTSIDE_DOMAIN, CLIPPED = (
    "ok", "near_axis", "negative", "above_max", "outside_domain", "clipped"
)

#: Efficiency band edges for the area shares (the last band includes 1.0).
BAND_EDGES = (0.0, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 1.0)

#: points of different sessions closer than this fraction of the largest |speed| and
#: torque are measurements of one operating point (a repeat) [-]
REPEAT_FRAC = 0.01

#: fewest pairs of repeats that estimate a loss repeatability (per quadrant, else pooled
#: over the campaign) [-]
MIN_REPEAT_PAIRS = 5

#: per-point column of the loss repeatability [W] (:func:`loss_repeatability`)
REPEAT_COLUMN = "loss_repeatability_w"


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
        floor of each point's uncertainty (:func:`point_uncertainty`), which sets
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
            "negative efficiency -> 0",
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


def nice_step(raw: float) -> float:
    """The smallest of 1, 2, 2.5 and 5 times a power of ten that is not below ``raw`` (> 0)."""
    if not (np.isfinite(raw) and raw > 0):
        return 1.0
    exp = np.floor(np.log10(raw))
    for m in (1.0, 2.0, 2.5, 5.0, 10.0):
        step = m * 10.0**exp
        if step >= raw * (1 - 1e-12):
            return float(step)
    return float(10.0 ** (exp + 1))  # unreachable: m = 10 always fits


#: Default number of map grid steps over the measured speed range and torque range.
GRID_SPEED_STEPS, GRID_TORQUE_STEPS = 180, 80


def grid_steps(frame) -> tuple[float, float]:
    """Default map spacing [rpm], [N m]: ~180 steps over the speed range, ~80 over the torque range.

    Rounded up to 1, 2, 2.5 or 5 times a power of ten (25 rpm and 1 N m for a
    -3000..1500 rpm, 0..78 N m campaign), so the map has the same resolution
    for any drive size.
    """
    span_s = float(np.ptp(frame["speed_rpm"])) if len(frame) else 0.0
    span_t = float(np.max(np.abs(frame["torque_nm"]))) if len(frame) else 0.0
    return nice_step(span_s / GRID_SPEED_STEPS), nice_step(span_t / GRID_TORQUE_STEPS)


def regular_grid(frame, speed_step_rpm: float, torque_step_nm: float):
    """Regular node vectors [rpm], [N m] covering the measured points' bounding box."""
    def axis(values, step):
        lo = np.floor(np.min(values) / step) * step
        hi = np.ceil(np.max(values) / step) * step
        return np.arange(lo, hi + step / 2, step)

    return axis(frame["speed_rpm"], speed_step_rpm), axis(frame["torque_nm"], torque_step_nm)


def _interpolate_in_hull(tri: Delaunay, values: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Piecewise-linear interpolation over a triangulation; NaN outside its convex hull.

    (What scipy's LinearNDInterpolator does, without its slow brute-force search
    for every query point outside the hull.)
    """
    out = np.full(len(query), np.nan)
    # cheap half-plane test first: find_simplex is slow for points outside the hull
    eq = ConvexHull(tri.points).equations
    candidate = np.all(query @ eq[:, :2].T + eq[:, 2] <= 1e-12, axis=1)
    simplex = np.full(len(query), -1)
    simplex[candidate] = tri.find_simplex(query[candidate])
    inside = simplex >= 0
    k = simplex[inside]
    transform = tri.transform[k]
    b = np.einsum("ijk,ik->ij", transform[:, :2], query[inside] - transform[:, 2])
    bary = np.column_stack([b, 1.0 - b.sum(axis=1)])
    out[inside] = np.einsum("ij,ij->i", values[tri.simplices[k]], bary)
    return out


def _column(frame: pd.DataFrame, name: str) -> np.ndarray:
    """A float column of ``frame``, or NaN throughout when it has none."""
    if name in frame.columns:
        return pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(frame), np.nan)


def power_uncertainty(frame: pd.DataFrame, power: str, accuracy_frac: float) -> np.ndarray:
    """Standard uncertainty of each point's mean power [W] (``power``: ``p_elec``/``p_mech``).

    The standard error of the window mean, ``<power>_w_std / sqrt(n_samples)``
    (the std alone when the point states no sample count, as a table with a std
    column but no count; 0 when it states no std), and ``accuracy_frac`` of the
    reading (the instruments' accuracy), added in quadrature.
    """
    value = np.abs(_column(frame, f"{power}_w"))
    std = _column(frame, f"{power}_w_std")
    n = _column(frame, "n_samples")
    with np.errstate(invalid="ignore", divide="ignore"):
        stat = np.where(np.isfinite(n) & (n > 0), std / np.sqrt(n), std)
    stat = np.where(np.isfinite(stat), stat, 0.0)
    return np.hypot(stat, accuracy_frac * value)


def point_uncertainty(frame: pd.DataFrame, rules: MaskingRules) -> np.ndarray:
    """Standard uncertainty of each point's efficiency (paper eqs. 1-2) [-].

    Both equations are a ratio of the two powers, so the relative uncertainties
    of ``P_elec`` and ``P_mech`` (:func:`power_uncertainty`) add in quadrature:
    ``u_eta = |eta| * sqrt((u_Pe / P_e)**2 + (u_Pm / P_m)**2 + (u_rep / P_e)**2)``;
    NaN where a power is 0. ``u_rep`` is the point's loss repeatability
    (column :data:`REPEAT_COLUMN` [W], 0 when absent; :func:`loss_repeatability`):
    a loss error ``dL`` at the point's exact ``P_mech`` changes eta by
    ``eta * dL / |P_e|`` in both quadrants.
    """
    eta = raw_efficiency(frame["p_mech_w"], frame["p_elec_w"])
    rel = []
    for power in ("p_elec", "p_mech"):
        u = power_uncertainty(frame, power, rules.accuracy_frac)
        with np.errstate(invalid="ignore", divide="ignore"):
            rel.append(u / np.abs(_column(frame, f"{power}_w")))
    repeat = np.nan_to_num(_column(frame, REPEAT_COLUMN))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel.append(repeat / np.abs(_column(frame, "p_elec_w")))
    return np.abs(eta) * np.sqrt(sum(r**2 for r in rel))


def efficiency_ceilings(frame: pd.DataFrame, rules: MaskingRules) -> dict[str, dict]:
    """The highest efficiency the map may show per quadrant: measured maximum plus its
    uncertainty.

    The maximum is taken over every point the masking rules leave ``ok`` (none is
    left out for being noisy, so the ceiling is never below an accepted point);
    the ceiling is that maximum plus that point's own standard uncertainty
    (:func:`point_uncertainty`), at most ``rules.max_efficiency``.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w``, ``quadrant``
        and, when known, ``p_elec_w_std``, ``p_mech_w_std``, ``n_samples``.
    rules : MaskingRules
        Only points the rules leave ``ok`` count as measured efficiencies.

    Returns
    -------
    dict
        ``quadrant -> {"eta": ceiling, "eta_max_measured", "noise_eta",
        "u_p_elec_w", "u_p_mech_w", "n_points", "speed_rpm", "torque_nm"}`` (the
        uncertainties and the place are those of the highest point), for each
        quadrant with at least one ``ok`` point.
    """
    eta, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    u_eta = point_uncertainty(frame, rules)
    u_pe = power_uncertainty(frame, "p_elec", rules.accuracy_frac)
    u_pm = power_uncertainty(frame, "p_mech", rules.accuracy_frac)
    quadrant = frame["quadrant"].to_numpy()
    out = {}
    for q in QUADRANTS:
        sel = np.flatnonzero((quadrant == q) & (status == OK))
        if sel.size == 0:
            continue
        k = int(sel[np.argmax(eta[sel])])
        noise = float(u_eta[k]) if np.isfinite(u_eta[k]) else 0.0
        out[q] = {"eta": float(min(eta[k] + noise, rules.max_efficiency)),
                  "eta_max_measured": float(eta[k]), "noise_eta": noise,
                  "u_p_elec_w": float(u_pe[k]), "u_p_mech_w": float(u_pm[k]),
                  "n_points": int(sel.size),
                  "speed_rpm": float(frame["speed_rpm"].iloc[k]),
                  "torque_nm": float(frame["torque_nm"].iloc[k])}
    return out


def gridded_map(
    frame: pd.DataFrame,
    rules: MaskingRules,
    *,
    model=None,
    speed_step_rpm: float | None = None,
    torque_step_nm: float | None = None,
) -> pd.DataFrame:
    """Efficiency map on a regular speed-torque grid (paper Fig. 5).

    Per quadrant: nodes outside the measured envelope (:func:`fitting.domain.
    quadrant_envelopes`) stay NaN (``outside_domain``); inside, the measured loss
    ``P_elec - P_mech`` is interpolated linearly over a Delaunay triangulation of
    the quadrant's points (in scaled coordinates), the node's electrical power is
    its exact ``omega * T`` plus that loss, and the efficiency follows by eqs. 1-2
    and the masking rules. An efficiency above the quadrant's ceiling
    (:func:`efficiency_ceilings`) is set to the ceiling and flagged ``clipped``.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w`` and ``quadrant``.
    rules : MaskingRules
    model : PowerModel, optional
        If given, adds the model's power and efficiency at each node (inside the domain).
    speed_step_rpm, torque_step_nm : float, optional
        Grid spacing [rpm], [N m]; default :func:`grid_steps`.

    Returns
    -------
    pandas.DataFrame
        One row per node: ``speed_rpm, torque_nm, quadrant, in_domain, p_mech_w,
        loss_w, p_elec_w, eta, status`` (and ``p_elec_fit_w, eta_fit`` with a model).
        ``attrs["envelopes"]`` and ``attrs["ceilings"]`` hold what the map used.
    """
    default_s, default_t = grid_steps(frame)
    speeds, torques = regular_grid(frame, speed_step_rpm or default_s, torque_step_nm or default_t)
    sg, tg = np.meshgrid(speeds, torques, indexing="ij")
    s, t = sg.ravel(), tg.ravel()
    envelopes = quadrant_envelopes(frame, rules.envelope_band_frac)
    ceilings = efficiency_ceilings(frame, rules)
    at = map_at(frame, rules, s, t, envelopes, ceilings)
    p_mech, quadrant = at["p_mech_w"], at["quadrant"]
    loss = honour_points(at["loss_w"].reshape(sg.shape), speeds, torques, quadrant.reshape(
        sg.shape), frame, rules, ceilings).ravel()
    eta, status = _shown(p_mech, quadrant, loss, rules, ceilings)
    in_domain = np.isfinite(loss)
    p_elec = p_mech + loss
    for q, ceiling in ceilings.items():
        ceiling["n_clipped_nodes"] = int(((quadrant == q) & (status == CLIPPED)).sum())
    out = pd.DataFrame({
        "speed_rpm": s, "torque_nm": t, "quadrant": quadrant, "in_domain": in_domain,
        "p_mech_w": p_mech, "loss_w": loss, "p_elec_w": p_elec, "eta": eta,
        "status": status.astype(str),
    })
    if model is not None:
        p_fit = np.asarray(model.p_elec_w(s, t), dtype=float)
        eta_fit, _ = masked_efficiency(p_mech, p_fit, rules)
        out["p_elec_fit_w"] = p_fit
        out["eta_fit"] = np.where(in_domain, eta_fit, np.nan)
    out.attrs["envelopes"] = envelopes
    out.attrs["ceilings"] = ceilings
    return out


def map_at(frame: pd.DataFrame, rules: MaskingRules, speed_rpm, torque_nm,
           envelopes: dict | None = None, ceilings: dict | None = None) -> dict[str, np.ndarray]:
    """The map's loss and efficiency at any speed-torque points (what :func:`gridded_map` draws).

    Per quadrant the measured loss ``P_elec - P_mech`` is interpolated linearly over
    a Delaunay triangulation of the quadrant's points (in coordinates scaled by the
    largest |speed| and torque), inside the quadrant's measured envelope only; the
    efficiency follows from the query's exact ``omega * T`` and that loss (eqs.
    1-2, masking rules), at most the quadrant's ceiling (``clipped``). At a measured
    point the interpolant is that point's own loss, so the map shows its efficiency,
    or the ceiling, which lies within its uncertainty (:func:`efficiency_ceilings`).

    Parameters
    ----------
    frame : pandas.DataFrame
        The measured points (``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w``,
        ``quadrant``).
    rules : MaskingRules
    speed_rpm, torque_nm : array_like
        Where to evaluate [rpm], [N m].
    envelopes, ceilings : dict, optional
        :func:`fitting.domain.quadrant_envelopes` and :func:`efficiency_ceilings` of
        ``frame`` (computed when not given).

    Returns
    -------
    dict
        ``p_mech_w``, ``quadrant``, ``loss_w`` (NaN outside the envelope), ``eta``
        and ``status`` (``outside_domain`` outside it) per query point.
    """
    s = np.asarray(speed_rpm, dtype=float).ravel()
    t = np.asarray(torque_nm, dtype=float).ravel()
    envelopes = (quadrant_envelopes(frame, rules.envelope_band_frac) if envelopes is None
                 else envelopes)
    ceilings = efficiency_ceilings(frame, rules) if ceilings is None else ceilings
    p_mech = s / RPM_PER_RAD_S * t
    quadrant = quadrant_of(p_mech)
    scales = (float(np.max(np.abs(frame["speed_rpm"]))) or 1.0,
              float(np.max(np.abs(frame["torque_nm"]))) or 1.0)
    loss = np.full(s.shape, np.nan)
    for q, env in envelopes.items():
        sub = frame[frame["quadrant"] == q]
        nodes = np.flatnonzero((quadrant == q) & in_polygon(env["polygon"], s, t))
        if nodes.size == 0:
            continue
        pts = np.column_stack([sub["speed_rpm"] / scales[0], sub["torque_nm"] / scales[1]])
        try:
            tri = Delaunay(pts)
        except QhullError:
            continue
        query = np.column_stack([s[nodes] / scales[0], t[nodes] / scales[1]])
        measured_loss = (sub["p_elec_w"] - sub["p_mech_w"]).to_numpy(dtype=float)
        loss[nodes] = _interpolate_in_hull(tri, measured_loss, query)
    eta, status = _shown(p_mech, quadrant, loss, rules, ceilings)
    return {"p_mech_w": p_mech, "quadrant": quadrant, "loss_w": loss, "eta": eta,
            "status": status}


def _shown(p_mech, quadrant, loss, rules: MaskingRules, ceilings: dict):
    """Efficiency and status the map shows for a loss at an exact ``p_mech`` (eqs. 1-2,
    masking rules, NaN loss ``outside_domain``, above the ceiling ``clipped``)."""
    eta, status = masked_efficiency(p_mech, p_mech + loss, rules)
    status[~np.isfinite(loss)] = OUTSIDE_DOMAIN
    for q, ceiling in ceilings.items():
        over = (quadrant == q) & (status == OK) & (eta > ceiling["eta"])
        eta[over] = ceiling["eta"]
        status[over] = CLIPPED
    return eta, status


def _bilinear(speeds, torques, speed_rpm, torque_nm):
    """Flat node indices ``(n, 4)`` of the cell around each point and their bilinear weights."""
    s = np.asarray(speed_rpm, dtype=float)
    t = np.asarray(torque_nm, dtype=float)
    i = np.clip(np.searchsorted(speeds, s) - 1, 0, max(speeds.size - 2, 0))
    j = np.clip(np.searchsorted(torques, t) - 1, 0, max(torques.size - 2, 0))
    i1, j1 = np.minimum(i + 1, speeds.size - 1), np.minimum(j + 1, torques.size - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        fs = np.nan_to_num(np.clip((s - speeds[i]) / (speeds[i1] - speeds[i]), 0.0, 1.0))
        ft = np.nan_to_num(np.clip((t - torques[j]) / (torques[j1] - torques[j]), 0.0, 1.0))
    nt = torques.size
    idx = np.column_stack([i * nt + j, i1 * nt + j, i * nt + j1, i1 * nt + j1])
    w = np.column_stack([(1 - fs) * (1 - ft), fs * (1 - ft), (1 - fs) * ft, fs * ft])
    return idx, w


def read_grid(map_frame: pd.DataFrame, speed_rpm, torque_nm) -> np.ndarray:
    """The loss a user reads off ``efficiency_map.parquet`` at any points [W].

    Bilinear in the cell of nodes around each point, over its in-domain nodes only
    (their weights renormalised; NaN when none is in the domain).
    """
    speeds = np.unique(map_frame["speed_rpm"].to_numpy(dtype=float))
    torques = np.unique(map_frame["torque_nm"].to_numpy(dtype=float))
    grid = np.full(speeds.size * torques.size, np.nan)
    k = (np.searchsorted(speeds, map_frame["speed_rpm"].to_numpy(dtype=float)) * torques.size
         + np.searchsorted(torques, map_frame["torque_nm"].to_numpy(dtype=float)))
    grid[k] = map_frame["loss_w"].to_numpy(dtype=float)
    idx, w = _bilinear(speeds, torques, speed_rpm, torque_nm)
    v = grid[idx]
    w = np.where(np.isfinite(v) & (w > 0), w, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (w * np.nan_to_num(v)).sum(axis=1) / w.sum(axis=1)


#: iterations of the projection that makes the grid honour the points (each a few
#: vector operations over the points)
HONOUR_ITERATIONS = 400


def loss_band(frame: pd.DataFrame, rules: MaskingRules) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the losses [W] at which the map shows its efficiency -/+ its uncertainty.

    ``lo`` is the loss of ``eta + u`` and ``hi`` that of ``eta - u`` at the point's exact
    ``P_mech`` (paper eqs. 1-2 solved for the loss; :func:`point_uncertainty`): a map
    loss within ``[lo, hi]`` shows the point's efficiency within its uncertainty.
    """
    p_mech = _column(frame, "p_mech_w")
    eta = raw_efficiency(p_mech, _column(frame, "p_elec_w"))
    u = np.nan_to_num(point_uncertainty(frame, rules))
    with np.errstate(invalid="ignore", divide="ignore"):
        motor = p_mech > 0
        lo = np.where(motor, p_mech / (eta + u) - p_mech, (1.0 - eta - u) * np.abs(p_mech))
        hi = np.where(motor, np.where(eta - u > 0, p_mech / (eta - u) - p_mech, np.inf),
                      (1.0 - eta + u) * np.abs(p_mech))
    return lo, hi


def honour_points(loss: np.ndarray, speeds: np.ndarray, torques: np.ndarray,
                  node_quadrant: np.ndarray, frame: pd.DataFrame, rules: MaskingRules,
                  ceilings: dict) -> np.ndarray:
    """Correct the grid's node losses so that, read as a user reads it (:func:`read_grid`),
    the map shows every accepted point's efficiency within its uncertainty.

    The nodes sample the interpolant of the measured losses, which passes through
    each point; between nodes a reader interpolates bilinearly, and where the
    measured loss varies faster than the grid's step (a noisy point, repeats that
    differ) the reading at a point can differ from its loss by more than its
    uncertainty. Each such point's reading is projected onto its band
    (:func:`loss_band`, shrunk by 2 % against round-off) by moving its cell's
    in-domain nodes in proportion to their weights, simultaneously for all points,
    each node by the mean of the moves asked of it (Cimmino's method) and kept
    between the lowest and highest band end of the points it serves (and its own
    value), until every reading is in its band or :data:`HONOUR_ITERATIONS` pass.
    Where two points in one cell ask for disjoint bands (repeats that disagree
    beyond their uncertainty) no node values satisfy both; a last pass then lowers
    only the readings above a band's upper end, so that no point lies above the
    map by more than its uncertainty (the other lies below it: counted by
    :func:`points_against_map`). Nodes no point's cell touches are unchanged.

    Parameters
    ----------
    loss : numpy.ndarray
        Node losses [W], shape ``(speeds.size, torques.size)`` (NaN outside the domain).
    speeds, torques : numpy.ndarray
        The grid's node vectors [rpm], [N m].
    node_quadrant : numpy.ndarray
        Quadrant of each node, the shape of ``loss``.
    frame, rules, ceilings
        The points, the masking rules and :func:`efficiency_ceilings`: points the rules
        leave ``ok`` in a quadrant with a ceiling are honoured.

    Returns
    -------
    numpy.ndarray
        The corrected node losses, the shape of ``loss``.
    """
    out = loss.ravel().copy()
    _, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    quadrant = frame["quadrant"].to_numpy()
    sel = (status == OK) & np.isin(quadrant, list(ceilings))
    if not sel.any() or speeds.size < 2 or torques.size < 2:
        return out.reshape(loss.shape)
    idx, w = _bilinear(speeds, torques, frame["speed_rpm"].to_numpy()[sel],
                       frame["torque_nm"].to_numpy()[sel])
    w = np.where(np.isfinite(out[idx]) & (node_quadrant.ravel()[idx] == quadrant[sel][:, None])
                 & (w > 0), w, 0.0)
    covered = w.sum(axis=1) > 0
    idx, w = idx[covered], w[covered] / w.sum(axis=1)[covered][:, None]
    lo, hi = (x[sel][covered] for x in loss_band(frame, rules))
    target = (_column(frame, "p_elec_w") - _column(frame, "p_mech_w"))[sel][covered]
    lo, hi = target - 0.98 * (target - lo), target + 0.98 * (hi - target)
    norm = (w**2).sum(axis=1)
    # no node leaves the range of its own value and the bands of the points it serves:
    # a correction never shows an efficiency no nearby point allows
    touched = idx[w > 0]
    floor, cap = out.copy(), out.copy()
    np.minimum.at(floor, touched, np.broadcast_to(lo[:, None], w.shape)[w > 0])
    np.maximum.at(cap, touched, np.broadcast_to(hi[:, None], w.shape)[w > 0])
    for one_sided in (False, True):
        for _ in range(HONOUR_ITERATIONS):
            reading = (w * np.nan_to_num(out[idx])).sum(axis=1)
            move = np.where(reading > hi, hi - reading, 0.0)
            if not one_sided:
                move = np.where(reading < lo, lo - reading, move)
            if not move.any():
                break
            step = w * (move / norm)[:, None]
            asked = w * (move != 0)[:, None] > 0
            total = np.bincount(idx.ravel(), step.ravel(), out.size)
            count = np.bincount(idx.ravel(), asked.ravel(), out.size)
            out = np.clip(out + np.where(count > 0, total / np.maximum(count, 1), 0.0),
                          floor, cap)
        else:
            continue
        break
    return out.reshape(loss.shape)


def points_against_map(frame: pd.DataFrame, rules: MaskingRules, map_frame: pd.DataFrame,
                       ceilings: dict) -> dict:
    """Per quadrant: do the accepted points lie on the map, as shipped, within their uncertainty?

    The map is read off its grid as a user reads it (:func:`read_grid`), its
    efficiency shown as :func:`gridded_map` shows it (at most the ceiling).

    Returns ``quadrant -> {"n_points", "n_above_map", "max_excess", "n_below_map",
    "n_off_map"}``: the ``ok`` points, those whose efficiency exceeds the map's at
    that point by more than their uncertainty (:func:`point_uncertainty`), the
    largest such excess [-] (0 when none), those below the map by more than their
    uncertainty (where the map is optimistic: a repeat that measured a lower loss
    nearby), and the points no in-domain node surrounds.
    """
    eta, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    u = np.nan_to_num(point_uncertainty(frame, rules))
    p_mech = _column(frame, "p_mech_w")
    quadrant = frame["quadrant"].to_numpy()
    loss = read_grid(map_frame, frame["speed_rpm"], frame["torque_nm"])
    shown, _ = _shown(p_mech, quadrant, loss, rules, ceilings)
    out = {}
    for q in ceilings:
        sel = (quadrant == q) & (status == OK)
        on = sel & np.isfinite(loss) & np.isfinite(shown)
        excess = np.where(on, eta - shown - u, -np.inf)
        below = np.where(on, shown - eta - u, -np.inf)
        out[q] = {"n_points": int(sel.sum()), "n_above_map": int((excess > 1e-12).sum()),
                  "max_excess": float(max(excess.max(initial=0.0), 0.0)),
                  "n_below_map": int((below > 1e-12).sum()),
                  "n_off_map": int((sel & ~on).sum())}
    return out


def repeat_pairs(frame: pd.DataFrame, rules: MaskingRules) -> tuple[np.ndarray, np.ndarray]:
    """Repeated measurements of one operating point: pairs ``(i, j)`` of row positions.

    Accepted (``ok``) points of one quadrant from different sessions that lie within
    :data:`REPEAT_FRAC` of the largest |speed| and torque of each other.
    """
    from scipy.spatial import cKDTree

    _, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    ok = np.flatnonzero(status == OK)
    if ok.size < 2:
        return np.zeros(0, int), np.zeros(0, int)
    scales = (float(np.max(np.abs(frame["speed_rpm"]))) or 1.0,
              float(np.max(np.abs(frame["torque_nm"]))) or 1.0)
    xy = np.column_stack([frame["speed_rpm"].to_numpy()[ok] / scales[0],
                          frame["torque_nm"].to_numpy()[ok] / scales[1]])
    pairs = cKDTree(xy).query_pairs(REPEAT_FRAC, p=np.inf, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    session = (frame["session_id"].to_numpy()[ok] if "session_id" in frame.columns
               else np.zeros(ok.size))
    quadrant = frame["quadrant"].to_numpy()[ok]
    i, j = pairs[:, 0], pairs[:, 1]
    keep = (session[i] != session[j]) & (quadrant[i] == quadrant[j])
    return ok[i[keep]], ok[j[keep]]


def loss_repeatability(frame: pd.DataFrame, rules: MaskingRules) -> dict:
    """How well the campaign's sessions repeat one operating point, as a loss [W].

    For each pair of repeats (:func:`repeat_pairs`) the losses ``L = P_elec - P_mech``
    differ by ``d``; the window statistics and the instruments' accuracy
    (:func:`power_uncertainty`) explain ``u_i**2 + u_j**2`` of ``d**2``. The
    repeatability is the pooled rest, per point::

        u_rep**2 = max(0, sum(d**2 - u_i**2 - u_j**2) / (2 n_pairs))

    (what a tare, a winding temperature or a fan that differs between sessions adds to
    one point's loss). It is pooled per quadrant when the quadrant has at least
    :data:`MIN_REPEAT_PAIRS` pairs, else over the campaign's pairs; with fewer (a
    campaign without repeated setpoints) it is 0: the fallback, said in a ``note``, so
    the points' uncertainty is their window statistics and instrument accuracy alone.

    Returns
    -------
    dict
        ``quadrant -> {"loss_w", "n_pairs", "pooled_over"}`` (``pooled_over``:
        ``quadrant``, ``campaign`` or ``none``) for each quadrant of ``frame``,
        ``rule``, and a ``note`` when the fallback applies.
    """
    i, j = repeat_pairs(frame, rules)
    loss = (_column(frame, "p_elec_w") - _column(frame, "p_mech_w"))
    u2 = sum(power_uncertainty(frame, p, rules.accuracy_frac) ** 2
             for p in ("p_elec", "p_mech"))
    excess = (loss[i] - loss[j]) ** 2 - u2[i] - u2[j]
    pair_q = frame["quadrant"].to_numpy()[i]

    def pooled(sel) -> float:
        return float(np.sqrt(max(0.0, np.sum(excess[sel]) / (2.0 * np.sum(sel)))))

    out: dict = {"rule": (
        "loss repeatability: pairs of accepted points of different sessions within "
        f"{REPEAT_FRAC:.0%} of the largest |speed| and torque; u_rep^2 = max(0, sum(d^2 - "
        "u_i^2 - u_j^2) / (2 n)) of their loss differences d beyond the window statistics "
        f"and instrument accuracy; per quadrant with >= {MIN_REPEAT_PAIRS} pairs, else "
        "pooled over the campaign, else 0 (no repeats)")}
    for q in dict.fromkeys(frame["quadrant"]):
        mine = pair_q == q
        if mine.sum() >= MIN_REPEAT_PAIRS:
            out[q] = {"loss_w": pooled(mine), "n_pairs": int(mine.sum()),
                      "pooled_over": "quadrant"}
        elif i.size >= MIN_REPEAT_PAIRS:
            out[q] = {"loss_w": pooled(np.ones(i.size, bool)), "n_pairs": int(i.size),
                      "pooled_over": "campaign"}
        else:
            out[q] = {"loss_w": 0.0, "n_pairs": int(mine.sum()), "pooled_over": "none"}
    if i.size < MIN_REPEAT_PAIRS:
        out["note"] = (
            f"repeatability not measured: {i.size} pair(s) of repeated operating points "
            f"across sessions (at least {MIN_REPEAT_PAIRS} needed); each point's uncertainty "
            "is its window statistics and instrument accuracy alone, which understates it "
            "when the sessions would not repeat")
    return out


def with_repeatability(frame: pd.DataFrame, repeat: dict) -> pd.DataFrame:
    """``frame`` with the column :data:`REPEAT_COLUMN`: each point's quadrant's loss
    repeatability [W] (:func:`loss_repeatability`)."""
    q = frame["quadrant"].to_numpy()
    values = np.array([repeat.get(k, {}).get("loss_w", 0.0) for k in q], dtype=float)
    return frame.assign(**{REPEAT_COLUMN: values})


def repeatability(frame: pd.DataFrame, rules: MaskingRules) -> dict:
    """Do repeated measurements of one operating point agree within their uncertainty?

    Pairs of repeats (:func:`repeat_pairs`); a pair disagrees when its efficiencies
    differ by more than twice their combined uncertainty: ``n_disagreeing_stated``
    with the window statistics and instrument accuracy alone, ``n_disagreeing`` with
    the loss repeatability too (:func:`point_uncertainty`, which reads
    :data:`REPEAT_COLUMN` when ``frame`` has it).

    Returns
    -------
    dict
        ``n_pairs``, ``n_disagreeing``, ``n_disagreeing_stated``,
        ``median_abs_diff_eta``, ``median_u_eta`` (with the repeatability; NaN without
        pairs), and a ``note`` when more than half of at least 5 pairs disagree.
    """
    eta, _ = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    u = point_uncertainty(frame, rules)
    u_stated = point_uncertainty(frame.drop(columns=REPEAT_COLUMN, errors="ignore"), rules)
    i, j = repeat_pairs(frame, rules)
    diff = np.abs(eta[i] - eta[j])
    combined = np.hypot(u[i], u[j])
    bad = diff > 2.0 * combined
    out = {"n_pairs": int(i.size), "n_disagreeing": int(bad.sum()),
           "n_disagreeing_stated": int((diff > 2.0 * np.hypot(u_stated[i], u_stated[j])).sum()),
           "median_abs_diff_eta": float(np.median(diff)) if i.size else float("nan"),
           "median_u_eta": float(np.median(combined)) if i.size else float("nan")}
    if i.size >= 5 and bad.sum() > 0.5 * i.size:
        out["note"] = (
            f"repeated operating points disagree: {int(bad.sum())} of {i.size} pairs of points "
            f"of different sessions within {REPEAT_FRAC:.0%} of the speed and torque range "
            f"differ by more than twice their uncertainty (median |d eta| "
            f"{out['median_abs_diff_eta']:.3g} against {out['median_u_eta']:.3g}): the "
            "sessions do not repeat within the instruments' accuracy (tare, temperature, a "
            "fault)")
    return out


def band_shares(map_frame: pd.DataFrame, edges=BAND_EDGES) -> pd.DataFrame:
    """Share of each quadrant's measured domain per efficiency band (regular grid: node share).

    Rows: quadrant x band, where the bands are the intervals of ``edges`` (``ok``
    and ``clipped`` nodes, by their shown efficiency) plus ``masked`` (near the
    axes or above max) and ``negative`` (set to 0).
    """
    rows = []
    for q in QUADRANTS:
        sub = map_frame[(map_frame["quadrant"] == q) & map_frame["in_domain"]]
        n = len(sub)
        if n == 0:
            continue
        ok = sub[sub["status"].isin((OK, CLIPPED))]["eta"].to_numpy()
        for k in range(len(edges) - 1):
            lo, hi = edges[k], edges[k + 1]
            last = k == len(edges) - 2
            inside = (ok >= lo) & ((ok <= hi) if last else (ok < hi))
            rows.append({"quadrant": q, "band": f"{lo:.2f}-{hi:.2f}", "eta_low": lo,
                         "eta_high": hi, "n_nodes": int(inside.sum()),
                         "area_share": float(inside.sum() / n)})
        for label, statuses in (("negative", (NEGATIVE,)), ("masked", (NEAR_AXIS, ABOVE_MAX))):
            k = int(sub["status"].isin(statuses).sum())
            rows.append({"quadrant": q, "band": label, "eta_low": np.nan, "eta_high": np.nan,
                         "n_nodes": k, "area_share": k / n})
    return pd.DataFrame(rows)


def peak_points(map_frame: pd.DataFrame, frame: pd.DataFrame, rules: MaskingRules) -> dict:
    """Peak efficiency per quadrant: on the gridded map and among the measured points.

    ``map`` is the shown peak (``ok`` or ``clipped`` nodes; ``clipped`` says whether
    it sits on the ceiling), ``measured`` the highest ``ok`` point, and ``ceiling``
    the map's ceiling (``map_frame.attrs["ceilings"]``) when known.
    """
    eta_pts, status_pts = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    ceilings = map_frame.attrs.get("ceilings", {})
    out = {}
    for q in QUADRANTS:
        entry = {}
        grid = map_frame[(map_frame["quadrant"] == q)
                         & map_frame["status"].isin((OK, CLIPPED))]
        if len(grid):
            row = grid.loc[grid["eta"].idxmax()]
            entry["map"] = {"speed_rpm": float(row["speed_rpm"]),
                            "torque_nm": float(row["torque_nm"]), "eta": float(row["eta"]),
                            "clipped": bool(row["status"] == CLIPPED)}
        sel = (frame["quadrant"].to_numpy() == q) & (status_pts == OK)
        if sel.any():
            k = int(np.flatnonzero(sel)[np.argmax(eta_pts[sel])])
            entry["measured"] = {"speed_rpm": float(frame["speed_rpm"].iloc[k]),
                                 "torque_nm": float(frame["torque_nm"].iloc[k]),
                                 "eta": float(eta_pts[k])}
        if q in ceilings:
            c = ceilings[q]
            entry["ceiling"] = {"eta": c["eta"], "eta_max_measured": c["eta_max_measured"],
                                "noise_eta": c["noise_eta"], "u_p_elec_w": c["u_p_elec_w"],
                                "u_p_mech_w": c["u_p_mech_w"], "n_points": c["n_points"],
                                "n_clipped_nodes": c.get("n_clipped_nodes", 0)}
        if entry:
            out[q] = entry
    return out
