"""The report's own provenance (issue 42): its command line as given (no option it was not
passed), and the IPOPT library the solves ran on in the version table."""

from __future__ import annotations

import re

from drivebench.cli import main


def test_report_records_its_command_line_as_given_and_ipopt(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["report", "--out", "r.html"]) == 0
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    row = re.search(r"<td>report</td><td><code>([^<]*)</code>", html)
    assert row is not None and row.group(1) == "bench report --out r.html"
    assert re.search(r"IPOPT \(the library CasADi loads\)</t[dh]><td[^>]*>3\.\d+\.\d+<", html)
