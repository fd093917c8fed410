"""The kernel every stage shares: one text/TOML reader naming file, line and encoding,
one JSON and one Parquet writer, one unit table."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from energy_fixtures import model_with_covariance, write_optimize_folder
from ingest_fixtures import make_points_session

from drivebench.cli import main
from kernel.errors import InputError
from kernel.files import read_json, read_text, read_toml, write_json, write_parquet
from kernel.units import RPM_PER_RAD_S, unit_of
from optimize.system.system import shipped_system_path

# a value of the file that is not ASCII, so the encodings differ in bytes
_COMMENT = "# Höhe über Grund, Kite-Hersteller: Müller\n"


def _encoded(text: str, encoding: str) -> bytes:
    return text.encode(encoding)


@pytest.mark.parametrize("encoding, fragment, line", [
    ("latin-1", "byte 0xf6 of the system file is not UTF-8 (Latin-1", 2),
    ("utf-16", "UTF-16", 1),
    ("utf-16-le", "NUL bytes", 1),
])
def test_system_file_in_another_encoding_exits_2_naming_file_line_and_encoding(
        tmp_path, capsys, encoding, fragment, line):
    text = "# a system file\n" + _COMMENT + shipped_system_path().read_text(encoding="utf-8")
    path = tmp_path / "kite.toml"
    path.write_bytes(_encoded(text, encoding))
    assert main(["optimize", "--system", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"kite.toml:{line}" in err and fragment in err and "UTF-8" in err, err
    assert "Traceback" not in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16"])
def test_mapping_file_in_another_encoding_exits_2(store_and_campaign, capsys, encoding):
    good, camp, store = store_and_campaign
    make_points_session(camp, "table_01")
    mp = camp / "table_01" / "mapping.toml"
    mp.write_bytes(_encoded(_COMMENT + mp.read_text(encoding="utf-8"), encoding))
    rc = main(["ingest", str(good), str(camp), "--store", str(store), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "mapping.toml:1" in err and "UTF-8" in err and "mapping file" in err, err


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16"])
def test_site_histogram_in_another_encoding_exits_2(tmp_path, capsys, encoding):
    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    site = tmp_path / "site.csv"
    site.write_bytes(_encoded("# Messmast Nord, 80 m über Grund\nv_m_s,hours\n4,100\n6,80\n",
                              encoding))
    code = main(["aep", "--optimize", str(folder), "--histogram", str(site),
                 "--out", str(tmp_path / "aep")])
    err = capsys.readouterr().err
    assert code == 2 and "site.csv:1" in err and "UTF-8" in err, err
    assert not (tmp_path / "aep").exists()


def test_utf8_with_byte_order_mark_reads_and_toml_error_names_its_line(tmp_path):
    path = tmp_path / "x.toml"
    path.write_bytes(b"\xef\xbb\xbfa = 1\n")
    assert read_toml(path) == {"a": 1} and read_text(path) == "a = 1\n"
    path.write_text("a = 1\nb = \n", encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_toml(path, what="site file")
    assert err.value.line == 2 and "site file is not valid TOML" in str(err.value)


def test_json_reader_names_file_line_and_what(tmp_path):
    path = tmp_path / "run.json"
    path.write_text('{"a": 1,\n "b": [1, 2,]}', encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_json(path, what="run record")
    assert err.value.path == path and err.value.line == 2
    assert "not valid JSON" in err.value.describe() and "run record" in err.value.describe()
    path.write_bytes('{"h\u00f6he_m": 1}'.encode("utf-16"))
    with pytest.raises(InputError, match="UTF-16"):
        read_json(path)
    path.write_text('\ufeff{"h\u00f6he_m": 1.5}', encoding="utf-8")
    assert read_json(path) == {"h\u00f6he_m": 1.5}


def test_json_writer_nulls_non_finite_and_keeps_old_file_on_failure(tmp_path):
    path = write_json(tmp_path / "m.json", {"a": 1.0, "b": float("nan"), "c": np.float64(2.5),
                                            "d": np.arange(2), "e": (np.inf,)})
    assert json.loads(path.read_text()) == {"a": 1.0, "b": None, "c": 2.5, "d": [0, 1],
                                            "e": [None]}
    with pytest.raises(TypeError):
        write_json(path, {"bad": object()})  # fails while serializing, before any write
    with pytest.raises(ValueError):
        write_json(path, {"b": math.nan}, non_finite="error")
    assert json.loads(path.read_text())["a"] == 1.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]


def test_parquet_writer_records_units_descriptions_and_file_metadata(tmp_path):
    frame = pd.DataFrame({"speed_rpm": [1.0], "torque_nm": [2.0], "eta": [0.9], "label": ["x"]})
    path = write_parquet(tmp_path / "t.parquet", frame, descriptions={"eta": "efficiency"},
                         metadata={"system": "kite text", "masking": {"k": 1}})
    schema = pq.read_schema(path)
    assert schema.field("speed_rpm").metadata == {b"unit": b"rpm"}
    assert schema.field("eta").metadata == {b"unit": b"1", b"description": b"efficiency"}
    assert schema.field("label").metadata is None
    assert schema.metadata[b"system"] == b"kite text"
    assert json.loads(schema.metadata[b"masking"]) == {"k": 1}
    pd.testing.assert_frame_equal(pd.read_parquet(path), frame)

    class Boom:
        pass

    with pytest.raises(Exception):  # noqa: B017 - pyarrow raises its own type
        write_parquet(path, pd.DataFrame({"x_m": [Boom()]}))
    pd.testing.assert_frame_equal(pd.read_parquet(path), frame)  # the old file is kept
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.parquet"]


def test_unit_table():
    # Truth: one revolution per minute is 2 pi rad per 60 s.
    assert 1500.0 / RPM_PER_RAD_S == pytest.approx(1500 * 2 * math.pi / 60, rel=1e-15)
    assert [unit_of(c) for c in ("torque_nm", "wind_speed_m_s", "tether_stiffness_n_per_m",
                                 "band_pct_nominal", "dcm_11", "scenario")] == [
        "N m", "m/s", "N/m", "% of nominal power", "1", ""]
