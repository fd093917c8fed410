"""The command line's own messages: ``bench --version``, errors about options."""

from __future__ import annotations

import re
from importlib import metadata

import casadi
import pytest

from drivebench.cli import main
from kernel.errors import InputError


def test_version_names_drivebench_casadi_and_ipopt(capsys):
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"drivebench {metadata.version('drivebench')} ")
    # issue 42: the Python API says the same version
    import drivebench

    assert out.split()[1] == drivebench.__version__
    assert f"CasADi {casadi.__version__}" in out
    # the IPOPT library CasADi loads answers with its own version (3.x.y)
    assert re.search(r"IPOPT 3\.\d+\.\d+\)", out), out


def test_an_option_error_names_no_file():
    err = InputError(None, "--scheduler tcp://nowhere:1: no scheduler answers",
                     expected="a running Dask scheduler")
    assert err.describe() == ("--scheduler tcp://nowhere:1: no scheduler answers; expected "
                              "a running Dask scheduler")
    with_file = InputError("a.csv", "bad number", line=3, column="torque_nm")
    assert with_file.describe() == "a.csv:3: column 'torque_nm': bad number"


def test_an_option_is_called_an_option_and_the_subcommand_named_in_full(tmp_path, capsys):
    # issue 42: `bench cycle export` errors began "bench cycle:" and said "column '--scenario'"
    err = InputError(tmp_path / "manifest.json", "no such scenario", column="--scenario")
    assert err.describe() == f"{tmp_path / 'manifest.json'}: option --scenario: no such scenario"
    code = main(["cycle", "export", "--optimize", str(tmp_path / "nowhere"),
                 "--scenario", "elec-lim-7.0", "--out", str(tmp_path / "p.csv")])
    text = capsys.readouterr().err
    assert code == 2 and text.startswith("bench cycle export: error: "), text
    assert "column '--" not in text
