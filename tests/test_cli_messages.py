"""The command line's own messages: ``bench --version``, errors about options."""

from __future__ import annotations

import re
from importlib import metadata

import casadi
import pytest

from bench.cli import main
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
