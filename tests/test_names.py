"""The names table (kernel/names.py, docs/names.md) against the code: the file is the table,
every name's unit is its suffix's, no two suffixes read alike, a retired name is used
nowhere in product code, and the sweep folder's columns are the table's names."""

from __future__ import annotations

import re
from pathlib import Path

from kernel.names import LOCAL_WIND, QUANTITIES, TERMS, WIND_SPEED, WINDING_TEMPERATURE, render
from kernel.units import UNIT_SUFFIXES, unit_of
from optimize.sweep_folder import SUMMARY_REQUIRED, TRAJECTORY_COLUMNS

ROOT = Path(__file__).resolve().parent.parent
PRODUCT = ("kernel", "bench", "fitting", "optimize", "energy", "cycle", "reports", "drivebench")


def product_sources() -> dict[Path, str]:
    return {p: p.read_text(encoding="utf-8") for package in PRODUCT
            for p in sorted((ROOT / package).rglob("*.py"))}


def test_docs_names_is_the_table():
    assert (ROOT / "docs" / "names.md").read_text(encoding="utf-8") == render()


def test_each_quantity_has_one_name_and_a_unit_from_its_suffix():
    names = [q.name for q in QUANTITIES]
    assert len(set(names)) == len(names)
    assert all(q.unit for q in QUANTITIES), [q.name for q in QUANTITIES if not q.unit]
    retired = [r for q in QUANTITIES for r in q.retired]
    assert not set(retired) & set(names) and len(set(retired)) == len(retired)
    assert len({t.term for t in TERMS}) == len(TERMS)


def test_no_two_unit_suffixes_read_alike():
    # "_n_m" (N/m) beside "_nm" (N m) read the same once the underscores are gone
    squeezed = [suffix.replace("_", "") for suffix, _ in UNIT_SUFFIXES]
    assert len(set(squeezed)) == len(squeezed)
    assert unit_of("nu_n_per_m") == "N/m" and unit_of("m_fict_x_nm") == "N m"


def retired_uses(sources: dict[Path, str]) -> list[str]:
    """``"old (now new) in file"`` for each retired name a source uses (the table aside)."""
    return [f"{old} (now {q.name}) in {p.name}" for q in QUANTITIES for old in q.retired
            for p, text in sources.items()
            if p.name != "names.py" and re.search(rf"\b{old}\b", text)]


def test_a_retired_name_appears_nowhere_in_product_code():
    assert retired_uses(product_sources()) == []


def test_the_local_wind_is_named_only_where_the_kites_trajectory_is():
    # wind_m_s is the wind at the kite; the stages after optimize see the reference wind only
    kite_side = ("optimize/model/", "optimize/problem/", "optimize/solve/", "optimize/analysis/")
    users = {str(p.relative_to(ROOT)) for p, text in product_sources().items()
             if re.search(rf"\b{LOCAL_WIND}\b", text)}
    assert users and all(u.startswith(kite_side) or u == "kernel/names.py" for u in users), users


def test_the_codes_names_are_the_tables():
    from optimize.model.kite_model import ALGEBRAIC
    from optimize.model.thermal import NODE_STATES, STATE

    named = {q.name for q in QUANTITIES}
    assert STATE == WINDING_TEMPERATURE and set(NODE_STATES) <= named
    assert "nu_n_per_m" in ALGEBRAIC.names and WIND_SPEED in SUMMARY_REQUIRED


def test_the_sweep_folders_columns_are_the_tables_names():
    named = {q.name for q in QUANTITIES}
    bookkeeping = {"scenario", "kind", "objective", "drive_limits", "success", "status",
                   "weight"}
    for column in (*TRAJECTORY_COLUMNS, *SUMMARY_REQUIRED):
        assert column in named | bookkeeping or column.startswith("peak_"), column


def test_the_checks_see_a_wrong_name():
    # a quantity without a unit suffix has no unit; a retired name in use is named
    from kernel.names import Name

    assert Name("wind_speed", "no suffix").unit == ""
    fake = {Path("aero.py"): "def f(wind_ref_m_s):\n    return 2 * wind_ref_m_s\n"}
    assert retired_uses(fake) == ["wind_ref_m_s (now wind_speed_m_s) in aero.py"]
