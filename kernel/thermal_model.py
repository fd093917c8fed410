"""The winding's thermal model of a drive, typed: a power model's ``thermal`` block
(docs/schemas.md §3), read by :meth:`ThermalModel.from_dict` and written back, key for
key and value for value, by :meth:`ThermalModel.to_dict`.

``bench fit`` fits it (:func:`fitting.thermal.fit_thermal`), the OCP flies it
(:class:`optimize.model.thermal.WindingThermal`), the similarity law carries it to another
rating (:meth:`ThermalModel.carried`) and the report tables it. The network is stated two
ways: ``modes`` (a Foster network, :class:`ThermalMode`) and ``ladder`` (the same network
node by node from the winding outwards, Cauer's form, :class:`ThermalNode`); a block
written before networks had more than one node states neither and is one node,
``tau_th_s dtheta/dt = ambient_c + r_th_k_per_w * heat_w - theta``.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

#: the block's keys in the order ``bench fit`` writes them (others follow in their order)
KEY_ORDER = ("version", "nodes", "model", "r_th_k_per_w", "r_th_k_per_w_ci95", "tau_th_s",
             "tau_th_s_ci95", "c_th_j_per_k", "c_th_j_per_k_ci95", "modes", "ladder",
             "copper_temp_coeff_per_k", "copper_temp_coeff_per_k_ci95", "theta_ref_c",
             "theta_points_c", "ambient_c", "session_ambient_c", "aux_load", "selection",
             "statistics", "sessions")
#: the figures that carry a 95 % interval (``<key>_ci95``) in the block, a mode and a node
_INTERVALS = ("r_th_k_per_w", "tau_th_s", "c_th_j_per_k", "copper_temp_coeff_per_k",
              "r_k_per_w", "tau_s", "c_j_per_k")
#: what the similarity law does to each figure: the power of the loss ratio it scales by
#: (resistances fall with it, heat capacities grow with it; time constants are kept)
_CARRIED_POWER = {"r_th_k_per_w": -1, "c_th_j_per_k": 1, "r_k_per_w": -1, "c_j_per_k": 1}


def _split(data: Mapping, typed: tuple[str, ...]) -> tuple[dict, dict, dict]:
    """``data``'s typed keys, their intervals and the other keys, each a dict."""
    values = {k: data[k] for k in typed if k in data}
    ci95 = {k: tuple(data[f"{k}_ci95"]) for k in _INTERVALS
            if isinstance(data.get(f"{k}_ci95"), (list, tuple))}
    taken = {*values, *(f"{k}_ci95" for k in ci95)}
    return values, ci95, {k: v for k, v in data.items() if k not in taken}


def _written(values: dict, ci95: Mapping, other: Mapping) -> dict:
    """The dict form: the values, each interval after its figure, then the other keys."""
    out = {}
    for key, value in values.items():
        out[key] = value
        if key in ci95:
            out[f"{key}_ci95"] = list(ci95[key])
    out.update({f"{k}_ci95": list(v) for k, v in ci95.items() if k not in values})
    return {**out, **copy.deepcopy(dict(other))}


def _scaled(item: Any, power_ratio: float) -> dict:
    """The figures of ``item`` the similarity law scales, and their intervals, scaled."""
    changes = {}
    ci95 = dict(item.ci95)
    for key, power in _CARRIED_POWER.items():
        factor = power_ratio**power
        if getattr(item, key, None) is not None:
            changes[key] = getattr(item, key) * factor
        if key in ci95:
            ci95[key] = tuple(v * factor for v in ci95[key])
    return {**changes, "ci95": ci95}


@dataclass(frozen=True, kw_only=True)
class ThermalMode:
    """One first-order mode of a Foster network: ``tau_s dtheta_i/dt = r_k_per_w heat_w -
    theta_i``.

    Attributes
    ----------
    r_k_per_w : float
        Its resistance [K/W].
    tau_s : float
        Its time constant [s].
    ci95 : Mapping
        Figure -> its 95 % interval ``(lo, hi)``.
    other : Mapping
        Keys of the block's mode besides these, as written.
    """

    r_k_per_w: float
    tau_s: float
    ci95: Mapping = field(default_factory=dict)
    other: Mapping = field(default_factory=dict)

    @classmethod
    def from_dict(cls, data: Mapping) -> ThermalMode:
        values, ci95, other = _split(data, ("r_k_per_w", "tau_s"))
        return cls(**values, ci95=ci95, other=other)

    def to_dict(self) -> dict:
        return _written({"r_k_per_w": self.r_k_per_w, "tau_s": self.tau_s}, self.ci95,
                        self.other)


@dataclass(frozen=True, kw_only=True)
class ThermalNode:
    """One node of the ladder (Cauer's form), from the winding outwards.

    Attributes
    ----------
    node : str or None
        Its name (``"winding"``, ``"housing"``).
    c_j_per_k : float
        Its heat capacity [J/K].
    r_k_per_w : float
        Its resistance to the next node (the last: to the ambient) [K/W].
    ci95 : Mapping
        Figure -> its 95 % interval ``(lo, hi)``.
    other : Mapping
        Keys of the block's node besides these, as written.
    """

    c_j_per_k: float
    r_k_per_w: float
    node: str | None = None
    ci95: Mapping = field(default_factory=dict)
    other: Mapping = field(default_factory=dict)

    @classmethod
    def from_dict(cls, data: Mapping) -> ThermalNode:
        values, ci95, other = _split(data, ("node", "c_j_per_k", "r_k_per_w"))
        return cls(**values, ci95=ci95, other=other)

    def to_dict(self) -> dict:
        values = {"node": self.node} if self.node is not None else {}
        return _written({**values, "c_j_per_k": self.c_j_per_k, "r_k_per_w": self.r_k_per_w},
                        self.ci95, self.other)

    @property
    def tau_s(self) -> float:
        """Its time constant ``r c`` [s]."""
        return self.r_k_per_w * self.c_j_per_k


@dataclass(frozen=True, kw_only=True)
class ThermalModel:
    """The winding's lumped thermal network and how its copper loss follows its temperature
    (docs/schemas.md §3 ``thermal``; ``None``: not stated in the block).

    Attributes
    ----------
    r_th_k_per_w : float
        Steady resistance winding to ambient [K/W].
    tau_th_s : float
        The winding's time constant [s] (with more nodes its step response's mean one).
    c_th_j_per_k : float
        ``tau_th_s / r_th_k_per_w`` [J/K].
    nodes : int or None
        How many nodes the network has (None: one).
    modes : tuple of ThermalMode or None
        The network as a sum of first-order modes.
    ladder : tuple of ThermalNode or None
        The same network node by node from the winding outwards (what the OCP flies).
    copper_temp_coeff_per_k : float or None
        Temperature coefficient of the copper's resistance [1/K].
    theta_ref_c : float or None
        Its reference temperature [degC].
    theta_points_c : float or None
        Where the power model's copper term holds: the fitted points' mean winding
        temperature [degC] (None: at ``theta_ref_c``).
    ambient_c : float or None
        The ambient of the fit, the reference of a prediction [degC].
    session_ambient_c : Mapping or None
        Session -> its fitted ambient [degC].
    aux_load : Mapping or None
        The auxiliary (non-heating) load ``g(theta)`` (:func:`fitting.thermal.aux_power_w`).
    selection, statistics : Mapping or None
        How many nodes the logs support, and the fit's statistics, as written.
    sessions : list or None
        The sessions fitted.
    ci95 : Mapping
        Figure -> its 95 % interval ``(lo, hi)``.
    other : Mapping
        The block's other keys as written (``version``, ``model``, ``carried``).
    """

    r_th_k_per_w: float
    tau_th_s: float
    c_th_j_per_k: float
    nodes: int | None = None
    modes: tuple[ThermalMode, ...] | None = None
    ladder: tuple[ThermalNode, ...] | None = None
    copper_temp_coeff_per_k: float | None = None
    theta_ref_c: float | None = None
    theta_points_c: float | None = None
    ambient_c: float | None = None
    session_ambient_c: Mapping | None = None
    aux_load: Mapping | None = None
    selection: Mapping | None = None
    statistics: Mapping | None = None
    sessions: list | None = None
    ci95: Mapping = field(default_factory=dict)
    other: Mapping = field(default_factory=dict)

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "thermal") -> ThermalModel:
        """The block of a power model file (checked by :mod:`fitting.model_schema`).

        Raises
        ------
        ValueError
            Not a mapping, or one of ``r_th_k_per_w``, ``tau_th_s``, ``c_th_j_per_k``
            missing (naming it).
        """
        if not isinstance(data, Mapping):
            raise ValueError(f"{where}: {data!r} is not an object of thermal keys")
        missing = [k for k in ("r_th_k_per_w", "tau_th_s", "c_th_j_per_k") if k not in data]
        if missing:
            raise ValueError(f"{where}: no {missing[0]!r}, a thermal model's figure")
        typed = tuple(f.name for f in dataclasses.fields(cls) if f.name not in ("ci95", "other"))
        values, ci95, other = _split(data, typed)
        if values.get("modes") is not None:
            values["modes"] = tuple(ThermalMode.from_dict(m) for m in values["modes"])
        if values.get("ladder") is not None:
            values["ladder"] = tuple(ThermalNode.from_dict(n) for n in values["ladder"])
        return cls(**values, ci95=ci95, other=other)

    def to_dict(self) -> dict:
        """The block as :meth:`from_dict` read it (docs/schemas.md §3)."""
        values = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in ("ci95", "other") or value is None:
                continue
            if f.name in ("modes", "ladder"):
                value = [item.to_dict() for item in value]
            values[f.name] = copy.deepcopy(value)
        out = _written(values, self.ci95, self.other)
        rank = {k: i for i, k in enumerate(KEY_ORDER)}
        return dict(sorted(out.items(), key=lambda kv: rank.get(kv[0], len(rank))))

    @property
    def node_count(self) -> int:
        """How many nodes the network has (1 when the block does not say)."""
        return 1 if self.nodes is None else int(self.nodes)

    def network(self) -> tuple[tuple[float, float], ...]:
        """Per node from the winding: its resistance to the next node (the last: to the
        ambient) [K/W] and its time constant [s]; one node is ``(r_th_k_per_w,
        tau_th_s)``.

        Raises
        ------
        ValueError
            A network of more nodes without its ladder.
        """
        if self.node_count == 1:
            return ((float(self.r_th_k_per_w), float(self.tau_th_s)),)
        if self.ladder is None:
            raise ValueError(f"thermal: {self.node_count} nodes but no 'ladder' stating them")
        return tuple((float(n.r_k_per_w), float(n.tau_s)) for n in self.ladder)

    def mode_figures(self) -> tuple[tuple[float, float], ...]:
        """The modes' ``(resistance [K/W], time constant [s])``; a block without modes is
        its one mode ``(r_th_k_per_w, tau_th_s)``."""
        if self.modes is not None:
            return tuple((m.r_k_per_w, m.tau_s) for m in self.modes)
        return ((self.r_th_k_per_w, self.tau_th_s),)

    def carried(self, power_ratio: float, law: str) -> ThermalModel:
        """This model carried to a drive with ``power_ratio`` times the losses at
        corresponding points: every resistance divided by it and every heat capacity
        multiplied by it, node by node and mode by mode, with their intervals; time
        constants, the copper coefficient and the temperatures kept; ``other["carried"]``
        records the ratio and ``law``."""
        parts = {key: tuple(dataclasses.replace(item, **_scaled(item, power_ratio))
                            for item in getattr(self, key))
                 for key in ("modes", "ladder") if getattr(self, key) is not None}
        other = {**self.other, "carried": {"power_ratio": power_ratio, "law": law}}
        return dataclasses.replace(self, **_scaled(self, power_ratio), **parts, other=other)
