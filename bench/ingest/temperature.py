"""Temperature channels of a bench log: which ones, their store columns, their checks.

A DAQ stream or single-stream log may carry the winding, housing, coolant or
ambient temperature (docs/schemas.md section 1), in degC or K (the unit is
checked like any other: :mod:`bench.ingest.column_units`). In the store each is
a column in degC (``t_winding_c``, ...) of the samples and, as the window mean,
of the points; NaN where a session did not log it.

A channel whose values, once in degC, leave :data:`PLAUSIBLE_C` (a column in K
labelled degC reads about 300 "degC"; one in degC labelled K about -250) is
refused with the file, the column and the unit it probably is. A channel that
never changes (a stuck or unplugged sensor) or holds no valid value is flagged
and not stored (NaN), with the file and the column named in the manifest's
``temperature_notes``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bench.ingest.column_units import unit_offset
from bench.store.schema import TEMPERATURE_COLUMNS
from kernel.errors import InputError

#: our temperature quantities (mapping keys and header aliases: docs/schemas.md section 1)
TEMPERATURES: tuple[str, ...] = ("t_winding", "t_housing", "t_coolant", "t_ambient")

#: the store column of each (degC)
STORE_COLUMN: dict[str, str] = dict(zip(TEMPERATURES, TEMPERATURE_COLUMNS, strict=True))

#: header names (unit stripped, lower case) recognised without a mapping
ALIASES: dict[str, tuple[str, ...]] = {
    "t_winding": ("t_winding", "winding temperature", "wicklungstemperatur", "t_wicklung",
                  "theta_winding", "t_winding_c"),
    "t_housing": ("t_housing", "housing temperature", "gehäusetemperatur", "t_gehaeuse",
                  "t_housing_c"),
    "t_coolant": ("t_coolant", "coolant temperature", "kühlmitteltemperatur", "t_coolant_c"),
    "t_ambient": ("t_ambient", "ambient temperature", "umgebungstemperatur", "t_ambient_c"),
}

#: the range a drive's temperature sensor can read, once in degC [degC] (insulation
#: class H allows 180 degC hot spot; a bench in a cold hall reads above -50 degC)
PLAUSIBLE_C = (-50.0, 250.0)


class TemperatureCheck:
    """Streamed range, change and validity of one temperature channel.

    Parameters
    ----------
    path : Path
        The data file (for messages).
    quantity : str
        One of :data:`TEMPERATURES`.
    column : str
        The file's column (for messages).
    unit : str
        Its unit as written (for messages).
    line_of_row : callable
        ``line_of_row(row) -> int or None``.
    """

    def __init__(self, path: Path, quantity: str, column: str, unit: str, line_of_row) -> None:
        self.path, self.quantity, self.column, self.unit = Path(path), quantity, column, unit
        self._line_of_row = line_of_row
        self.lo, self.hi, self.n_valid = math.inf, -math.inf, 0

    def feed(self, values_c: np.ndarray, row0: int) -> None:
        """Take one chunk in degC (first row ``row0``); refuse an implausible value."""
        ok = np.isfinite(values_c)
        if not ok.any():
            return
        bad = ok & ((values_c < PLAUSIBLE_C[0]) | (values_c > PLAUSIBLE_C[1]))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            self._refuse(float(values_c[k]), self._line_of_row(row0 + k))
        v = values_c[ok]
        self.lo, self.hi = min(self.lo, float(v.min())), max(self.hi, float(v.max()))
        self.n_valid += int(v.size)

    def _refuse(self, value_c: float, line: int | None) -> None:
        kelvin = unit_offset("temperature", self.unit) != 0.0
        if kelvin and value_c < PLAUSIBLE_C[0]:
            guess = "degC (the column reads like degC labelled K)"
        elif not kelvin and value_c > PLAUSIBLE_C[1]:
            guess = "K (the column reads like kelvin labelled degC)"
        else:
            guess = "not a temperature (or a faulty sensor)"
        raise InputError(
            self.path, f"{self.quantity} reads {value_c:.6g} degC once converted from "
            f"{self.unit!r}, outside any plausible drive temperature; the unit is probably {guess}",
            line=line, column=self.column,
            expected=f"{PLAUSIBLE_C[0]:g} to {PLAUSIBLE_C[1]:g} degC after conversion; "
                     "fix the unit in the header or the mapping",
        )

    def note(self) -> str | None:
        """Why the channel is not stored (no valid value, or constant), else None."""
        where = f"{self.path.name} column {self.column!r}"
        if self.n_valid == 0:
            return f"{self.quantity}: {where} holds no valid value (sensor missing): not stored"
        if self.hi == self.lo:
            return (f"{self.quantity}: {where} is constant at {self.lo:g} degC over "
                    f"{self.n_valid} samples (stuck or unplugged sensor): not stored")
        return None
