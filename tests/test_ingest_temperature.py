"""Temperature channels in bench logs: recognised by name, degC or K, checked for a wrong
unit (refused, naming the file and column, store untouched), flagged when constant or
missing (not stored), stored in degC in the samples and as window means in the points."""

from __future__ import annotations

import json

import numpy as np
import pytest
from ingest_fixtures import make_timeseries_session
from test_ingest_bad_input import _fails

from bench.store.read import read_points, read_samples
from drivebench.cli import main

KELVIN = 273.15


def _add_column(daq, header: str, values) -> None:
    """Append a column ``header`` holding ``values`` (one per data row) to a DAQ CSV."""
    lines = daq.read_text().splitlines()
    body = [f"{row},{float(v)!r}" for row, v in zip(lines[1:], values, strict=True)]
    daq.write_text("\n".join([f"{lines[0]},{header}", *body]) + "\n")


def _rows(daq) -> int:
    return len(daq.read_text().splitlines()) - 1


def _ramp_c(n: int) -> np.ndarray:
    """A winding warming from 25 to 60 degC (a 0.01 K resolution sensor)."""
    return np.round(np.linspace(25.0, 60.0, n), 2)


@pytest.mark.parametrize("header, offset", [("T_winding [degC]", 0.0),
                                            ("Winding temperature [K]", KELVIN)])
def test_winding_temperature_is_stored_in_degc(tmp_path, header, offset):
    camp = tmp_path / "camp"
    make_timeseries_session(camp, "m_01", markers=False)
    daq = camp / "m_01" / "daq.csv"
    true_c = _ramp_c(_rows(daq))
    _add_column(daq, header, np.round(true_c + offset, 2))
    store = tmp_path / "store"
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    samples = read_samples(store, "m_01")
    np.testing.assert_allclose(samples.t_winding_c, true_c[:len(samples)], atol=1e-9)
    assert samples.t_coolant_c.isna().all()
    pts = read_points(store)
    inside = samples[samples.point_id >= 0].groupby("point_id").t_winding_c.mean()
    np.testing.assert_allclose(pts.t_winding_c, inside.to_numpy(), atol=1e-9)
    assert pts.t_winding_c.between(25.0, 60.0).all()


@pytest.mark.parametrize("header, values, fragments", [
    # kelvin labelled degC: reads about 300 degC
    ("T_winding [degC]", lambda n: _ramp_c(n) + KELVIN,
     ["daq.csv:2", "column 'T_winding [degC]'", "298.15 degC", "probably K"]),
    # degC labelled K: reads about -248 degC
    ("T_winding [K]", _ramp_c, ["column 'T_winding [K]'", "-248.15 degC", "probably degC"]),
    ("T_winding [F]", _ramp_c, ["column 'T_winding [F]'", "unknown unit 'F'", "degC"]),
])
def test_wrong_temperature_unit_is_refused(store_and_campaign, capsys, header, values,
                                           fragments):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"
    _add_column(daq, header, values(_rows(daq)))
    _fails(store_and_campaign, capsys, *fragments)


@pytest.mark.parametrize("values, why", [(lambda n: np.full(n, 21.5), "constant at 21.5 degC"),
                                         (lambda n: ["NAN"] * n, "no valid value")])
def test_constant_or_missing_sensor_is_flagged_not_stored(tmp_path, capsys, values, why):
    camp = tmp_path / "camp"
    make_timeseries_session(camp, "m_01", markers=False)
    daq = camp / "m_01" / "daq.csv"
    cells = values(_rows(daq))
    lines = daq.read_text().splitlines()
    daq.write_text("\n".join([lines[0] + ",T_winding [degC]"] + [
        f"{r},{c}" for r, c in zip(lines[1:], cells, strict=True)]) + "\n")
    store = tmp_path / "store"
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "m_01: temperature flagged: t_winding: daq.csv column 'T_winding [degC]'" in out
    assert why in out
    manifest = json.loads((store / "manifest.json").read_text())
    assert why in manifest["sessions"]["m_01"]["temperature_notes"][0]
    assert read_samples(store, "m_01").t_winding_c.isna().all()
    assert read_points(store).t_winding_c.isna().all()
