"""Named vectors of a model: its states, controls, algebraic variables, fictitious forces.

A model (:class:`optimize.model.dae.Dae`) names every component of its vectors,
each name ending in its unit (``dl_m_s``, ``nu_n_per_m``; :func:`kernel.units.unit_of`
reads it), so the transcription, the initial guess, the scaling, the results and
the trust checks find a component by name and size every vector from the model
instead of from constants of one model.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from kernel.units import unit_of


@dataclass(frozen=True)
class Variables:
    """The components of one vector of a model, in order.

    Attributes
    ----------
    names : tuple of str
        Component names, each ending in its unit suffix (``"dl_m_s"`` is in m/s).
    """

    names: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"repeated variable names in {self.names}")
        unitless = [name for name in self.names if not unit_of(name)]
        if unitless:
            raise ValueError(f"no unit suffix in the variable names {', '.join(unitless)}")

    @property
    def size(self) -> int:
        """Number of components."""
        return len(self.names)

    @property
    def units(self) -> tuple[str, ...]:
        """Unit of each component (from its name)."""
        return tuple(unit_of(name) for name in self.names)

    def index(self, name: str) -> int:
        """Position of component ``name``."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no variable {name!r}; known: {', '.join(self.names)}") from None

    def indices(self, names: Iterable[str]) -> list[int]:
        """Positions of the components ``names``, in their order."""
        return [self.index(name) for name in names]

    def vector(self, values: Mapping[str, float]) -> np.ndarray:
        """An array in this order from a value per name (every name required)."""
        missing = [name for name in self.names if name not in values]
        if missing:
            raise KeyError(f"no value for {', '.join(missing)}")
        return np.array([float(values[name]) for name in self.names])
