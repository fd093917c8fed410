"""The system file's keys are declared once (optimize/system/sections.py): the one reader
builds every section from them with errors naming file, section, key and range, and
docs/system_file.md's key tables are rendered from them (as docs/cli.md and docs/names.md
are from the code)."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

from kernel.errors import InputError
from kernel.sections import key_table, keys, number, read_section, text
from kernel.units import unit_of
from optimize.system import system_doc
from optimize.system.sections import SECTIONS
from optimize.system.system import SYSTEMS_DIR, shipped_system_path
from optimize.system.system_file import system_from_dict

DOC = Path(__file__).resolve().parent.parent / "docs" / "system_file.md"
#: keys whose quantity has no unit
DIMENSIONLESS = {"drag_coefficient", "gear_ratio", "overload", "safety_factor", "exponent",
                 "drag_elements"}


def test_the_page_holds_the_tables_the_sections_render():
    page = DOC.read_text(encoding="utf-8")
    assert system_doc.render(page) == page, (
        "docs/system_file.md's key tables are stale: run "
        "python -m optimize.system.system_doc docs/system_file.md")
    for name, cls in SECTIONS.items():
        assert all(f"| `{k}` |" in page or f"`{k}`," in page or f", `{k}` |" in page
                   for k, _ in keys(cls)), name


def test_every_number_key_has_the_unit_of_its_name():
    missing = [f"[{s}] {k}" for s, cls in SECTIONS.items() for k, key in keys(cls)
               if key.kind in ("number", "numbers") and k not in DIMENSIONLESS
               and not unit_of(k)]
    assert missing == []
    assert unit_of("max_body_rate_deg_s") == "deg/s" and unit_of("mass_kg_m") == "kg/m"


def test_every_shipped_key_is_declared():
    declared = {(s, k) for s, cls in SECTIONS.items() for k, _ in keys(cls)}
    for path in sorted(SYSTEMS_DIR.glob("*.toml")):
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        given = {(s, k) for s, table in data.items() for k in table}
        assert given <= declared, (path.name, sorted(given - declared))


def _error(section: str, key: str, value: object) -> str:
    data = tomllib.loads(shipped_system_path().read_text(encoding="utf-8"))
    data[section][key] = value
    with pytest.raises(InputError) as info:
        system_from_dict(data, "my_kite.toml")
    return str(info.value)


@pytest.mark.parametrize(("section", "key", "value", "words"), [
    ("kite", "mass_kg", -7.5, "a number > 0 kg"),
    ("tether", "density_kg_m3", 50.0, "a number from 100 to 20000 kg/m^3"),
    ("bounds", "max_line_angle_deg", 95.0, "a number > 0 and < 90 deg"),
    ("bounds", "max_body_rate_deg_s", 0.0, "a number > 0 deg/s"),
    ("tether", "drag_elements", 0, "an integer from 1 to 100"),
    ("drive", "scaling", "linear", "one of similarity, similarity-ie3, none"),
])
def test_an_error_names_file_section_key_and_range(section, key, value, words):
    text_ = _error(section, key, value)
    assert "my_kite.toml" in text_ and f"[{section}] {key}" in text_ and words in text_


@dataclass(frozen=True, kw_only=True)
class _Reel:
    """A section of one required key, one optional key with a default and one choice."""

    time_constant_s: float = number("the filter's time constant", lo=0)
    gain: float = number("its gain", lo=0, hi=10, lo_strict=False, default=1.0)
    mode: str = text("how it filters", choices=("low", "high"), default="low")

    def problems(self) -> list[tuple[str, str, str]]:
        if self.mode == "high" and self.gain == 0:
            return [("gain", "0 with mode high", "a gain > 0")]
        return []


def test_a_declared_section_is_read_checked_and_documented():
    reel = read_section(_Reel, {"time_constant_s": 0.5}, "f.toml", "reel")
    assert reel == _Reel(time_constant_s=0.5, gain=1.0, mode="low")
    for table, words in (({}, "[reel] time_constant_s: missing"),
                         ({"time_constant_s": "fast"}, "'fast' is not a number"),
                         ({"time_constant_s": 1, "gain": 11}, "a number from 0 to 10"),
                         ({"time_constant_s": 1, "mode": "high", "gain": 0},
                          "[reel] gain: 0 with mode high"),
                         ({"time_constant_s": 1, "tau_s": 1}, "[reel] tau_s: unknown key")):
        with pytest.raises(InputError, match=r"f\.toml") as info:
            read_section(_Reel, table, "f.toml", "reel")
        assert words in str(info.value)
    table = key_table(_Reel)
    assert "| `time_constant_s` | s | > 0 | required | the filter's time constant |" in table
    assert "| `gain` | - | 0 to 10 | `1` | its gain |" in table
    assert '| `mode` | - | "low", "high" | `"low"` | how it filters |' in table


def test_a_page_without_a_sections_markers_is_refused():
    with pytest.raises(ValueError, match=r"\[reel\]"):
        system_doc.render("# a page\n", {"reel": _Reel})


def test_the_generator_rewrites_the_checkouts_page_by_default_and_refuses_a_missing_one(
        tmp_path, capsys):
    from optimize.system import system_doc

    assert system_doc.PAGE.is_file()  # the command the page's markers name works as written
    page = tmp_path / "system_file.md"
    page.write_text(system_doc.PAGE.read_text())
    assert system_doc.main([str(page)]) == 0
    assert page.read_text() == system_doc.PAGE.read_text()  # the shipped page is current
    with pytest.raises(SystemExit) as exit_info:
        system_doc.main([str(tmp_path / "missing.md")])
    assert exit_info.value.code == 2
    assert "missing.md: no such page" in capsys.readouterr().err
