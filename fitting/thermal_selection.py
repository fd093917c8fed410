"""How many thermal nodes the logs support: held-out prediction and the one-SE rule.

The same kind of rule as the power model's term selection (:mod:`fitting.selection`):
each candidate network (1 or 2 nodes, :mod:`fitting.thermal_network`) is fitted with
one segment of the logs left out and predicts that segment's winding temperature
from its first reading (the modes sharing that rise as under a steady heat, the
ambient the fitted mean); the candidate with the fewest nodes whose mean held-out
RMS is within one standard error (over the segments) of the lowest is chosen.

Segments are the sessions that log the winding temperature when there are at least
:data:`MIN_SESSIONS`; with fewer, each such session is cut into :data:`BLOCKS`
contiguous blocks, each with its own start temperature and ambient.
"""

from __future__ import annotations

import numpy as np

from fitting.thermal_network import fit_chain, simulate_modes

#: candidate numbers of nodes
CANDIDATES = (1, 2)
#: fewest sessions to leave out one at a time; with fewer, blocks of sessions
MIN_SESSIONS = 3
#: blocks per session when sessions are too few
BLOCKS = 3
RULE = ("fewest nodes whose mean RMS of the winding temperature predicted for a held-out "
        "segment (from its first reading) is within one standard error of the lowest")


def segments(series: dict[str, dict]) -> tuple[dict[str, dict], str]:
    """The held-out units of ``series`` (session id -> binned series) and their kind
    (``"session"`` or ``"block"``)."""
    if len(series) >= MIN_SESSIONS:
        return series, "session"
    out = {}
    for sid, d in series.items():
        edges = np.linspace(0, d["heat_w"].size, BLOCKS + 1).astype(int)
        for k in range(BLOCKS):
            part = slice(edges[k], edges[k + 1])
            theta = d["theta_c"][part]
            if np.isfinite(theta).sum() >= 2:
                out[f"{sid}[{k + 1}/{BLOCKS}]"] = {"heat_w": d["heat_w"][part],
                                                    "theta_c": theta, "bin_s": d["bin_s"]}
    return out, "block"


def predict(modes: np.ndarray, ambient_c: float, d: dict) -> np.ndarray:
    """Bin means [degC] of a segment's winding temperature from its first reading."""
    measured = d["theta_c"]
    theta0 = float(measured[np.isfinite(measured)][0])
    return simulate_modes(d["heat_w"], theta0, ambient_c, modes, d["bin_s"])


def held_out_rms(units: dict[str, dict], candidates: tuple[int, ...]
                 ) -> dict[int, dict[str, float]]:
    """Per candidate number of nodes and per unit: the RMS [K] of the unit's predicted
    winding temperature, the network fitted on the other units (one
    :func:`fitting.thermal_network.fit_chain` per unit serves every candidate)."""
    out: dict[int, dict[str, float]] = {n: {} for n in candidates}
    for name, d in units.items():
        chain = fit_chain({k: v for k, v in units.items() if k != name}, max(candidates))
        for n in candidates:
            fit = chain[n - 1]
            ambient = float(np.mean(list(fit["ambient_c"].values())))
            err = (predict(fit["modes"], ambient, d) - d["theta_c"])[np.isfinite(d["theta_c"])]
            out[n][name] = float(np.sqrt(np.mean(err**2)))
    return out


def select_nodes(series: dict[str, dict], candidates: tuple[int, ...] = CANDIDATES) -> dict:
    """Cross-validate each candidate and choose by the one-standard-error rule.

    Returns
    -------
    dict
        ``rule``, ``unit`` (session or block), ``chosen_nodes`` and ``candidates``:
        per candidate ``nodes``, ``cv_rms_k`` (the mean held-out RMS), ``cv_rms_k_se``
        and ``held_out_rms_k`` (per unit). With a single unit nothing can be held out:
        one node, ``chosen_nodes`` 1 and the reason in ``note``.
    """
    units, unit = segments(series)
    if len(units) < 2:
        return {"rule": RULE, "unit": unit, "chosen_nodes": 1, "candidates": [],
                "note": "one node: too little logged temperature to hold a part out"}
    rows = []
    for n, rms in held_out_rms(units, candidates).items():
        v = np.array(list(rms.values()))
        rows.append({"nodes": n, "cv_rms_k": float(v.mean()),
                     "cv_rms_k_se": float(v.std(ddof=1) / np.sqrt(v.size)),
                     "held_out_rms_k": rms})
    best = min(rows, key=lambda r: r["cv_rms_k"])
    chosen = min(r["nodes"] for r in rows
                 if r["cv_rms_k"] <= best["cv_rms_k"] + best["cv_rms_k_se"])
    return {"rule": RULE, "unit": unit, "chosen_nodes": chosen, "candidates": rows}
