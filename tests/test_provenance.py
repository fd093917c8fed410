"""Every stage's record carries the one provenance header (docs/schemas.md "Provenance
header"): when, which command line, which run, which versions; the record's run id is its
folder's ``run.json`` run id. The fit stage's check is in tests/fitting/test_fit_cli.py."""

from __future__ import annotations

import json
from datetime import UTC, datetime

import pytest
from energy_fixtures import model_with_covariance, write_optimize_folder

from drivebench.cli import main
from kernel.provenance import HEADER_FIELDS, Provenance, command_text, read_header
from kernel.versions import package_versions


def check_header(record: dict, command_line: list[str], folder=None) -> dict:
    """The header of ``record``: every field, this command line, fresh, today's versions,
    and (``folder``) the run id of the folder's ``run.json``."""
    header = read_header(record)
    assert header is not None and set(header) == set(HEADER_FIELDS)
    assert header["command_line"] == command_line
    age = datetime.now(UTC) - datetime.fromisoformat(header["created_utc"])
    assert 0 <= age.total_seconds() < 600
    assert header["versions"] == package_versions() and len(header["run_id"]) == 32
    if folder is not None:
        run = json.loads((folder / "run.json").read_text(encoding="utf-8"))
        assert run["run_id"] == header["run_id"] and run["provenance"] == header
    return header


def test_ingest_writes_the_header_into_the_store_manifest(store_and_campaign):
    good, _, store = store_and_campaign
    manifest = json.loads((store / "manifest.json").read_text(encoding="utf-8"))
    check_header(manifest, ["bench", "ingest", str(good), "--store", str(store),
                            "--no-progress"])


def test_aep_writes_the_header_into_aep_json_and_run_json(tmp_path, capsys):
    opt = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    argv = ["aep", "--optimize", str(opt), "--out", str(tmp_path / "aep"),
            "--weibull-k", "2", "--mean-speed", "5.5", "--no-progress"]
    assert main(argv) == 0
    doc = json.loads((tmp_path / "aep" / "aep.json").read_text(encoding="utf-8"))
    check_header(doc, ["bench", *argv], tmp_path / "aep")


def test_size_writes_the_header_into_sizing_json_and_run_json(tmp_path):
    from test_energy_sizing import CrashingBackend, _candidates, _handle

    from energy.decision import decision, grid_coverage
    from energy.site import Weibull
    from energy.sizing import run_sizing
    from energy.sizing_files import write_sizing
    from optimize.paper_model import paper_model
    from optimize.system.drive_in_force import drive_in_force
    from optimize.system.system_file import load_system

    site, winds = Weibull(2.0, 6.2), (6.0, 7.0)
    res = run_sizing(_candidates((1.0,)), winds, site, tmp_path / "solves", n_intervals=10,
                     handle=_handle(), show_progress=False,
                     backend=CrashingBackend(crash_at=None))
    system = load_system()
    run = Provenance.start(["drivebench.size"])
    coverage = grid_coverage(site, winds, res.records)
    drive, how = drive_in_force(system, drive_model=paper_model())
    write_sizing(tmp_path / "size", res, site=site, site_note="test", system=system,
                 drive=drive, resolution=how, wind_speeds_m_s=winds,
                 adaptive=False, tolerance=0.02, notes=[], provenance=run, coverage=coverage,
                 decision=decision(res.table, res.records, site, coverage, 0.02))
    doc = json.loads((tmp_path / "size" / "sizing.json").read_text(encoding="utf-8"))
    assert check_header(doc, ["drivebench.size"], tmp_path / "size") == run.header()


def test_optimize_writes_the_header_into_the_manifest_and_run_json(tmp_path):
    from test_sweep import CycleBackend

    from optimize.command import SweepRequest, run_optimize
    from optimize.paper_model import PAPER_MODEL_PATH, paper_model
    from optimize.resolve import resolve
    from optimize.sweep_options import WindGrid

    out = tmp_path / "optimize_out"
    request = SweepRequest(grid=WindGrid((5.5, 7.0), ("elec-lim",)),
                           setup=resolve(drive_model=paper_model(),
                                         model_path=PAPER_MODEL_PATH),
                           model_note="paper model", workers=1, out=out, claims=False)
    run_optimize(request, ["bench", "optimize", "--wind-grid", "5.5,7"], show_progress=False,
                 backend=CycleBackend())
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    header = check_header(manifest, ["bench", "optimize", "--wind-grid", "5.5,7"], out)
    assert command_text(header) == "bench optimize --wind-grid 5.5,7"


def test_a_broken_header_is_named():
    from kernel.errors import InputError

    record = {"provenance": {**Provenance.start(["x"]).header(), "command_line": "x"}}
    with pytest.raises(InputError, match="command_line"):
        read_header(record, "manifest.json")
    assert read_header({"schema": "drivebench.optimize"}) is None  # written before the header
