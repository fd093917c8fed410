"""A sweep keeps its seed's optimum (``start.npz``) as the start of the next sweep of
the same system (``bench optimize --start``), refused for any other system.

Truth: the second sweep's seed is the first one's optimum, so IPOPT's convergence check
accepts it within its two iterations and the optimum is the same to the 0.05 W by which
the sweep tells two optima apart (``local_optima.better_margin_w``); the first sweep's
seed came from the homotopy (AP2 has no shipped start).
"""

from __future__ import annotations

import json

import pytest

from kernel.errors import InputError
from optimize.command import make_request, run_optimize
from optimize.sweep_folder import START_FILE
from optimize.sweep_options import Execution, SolverChoice, WindGrid
from optimize.system.system import shipped_system_path

GRID = WindGrid((8.0,), ("elec-lim",))


def _request(out, system="ap2", start=None):
    return make_request(GRID, SolverChoice(n_intervals=10, degree=3, start=start),
                        system=shipped_system_path(system), out=out,
                        execution=Execution(workers=1), claims=False)


@pytest.fixture(scope="module")
def first(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweeps") / "first"
    return out, run_optimize(_request(out), ["bench", "optimize"], show_progress=False)


def test_a_sweep_keeps_its_seed_and_the_next_one_starts_there(first, tmp_path):
    out, done = first
    row = done.summary.iloc[0]
    assert row["success"] and row["warm_source"] == "cold start"
    assert done.files["start"] == out / START_FILE and (out / START_FILE).is_file()
    again = run_optimize(_request(tmp_path / "second", start=out), ["bench", "optimize"],
                         show_progress=False)
    row2 = again.summary.iloc[0]
    assert row2["success"] and row2["warm_source"] == "stored guess"
    assert row2["iterations"] <= 2  # the check at the first sweep's optimum
    assert row2["avg_p_elec_w"] == pytest.approx(row["avg_p_elec_w"], abs=0.05)


def test_a_start_of_another_system_is_refused_before_any_solve(first, tmp_path):
    out, _ = first
    with pytest.raises(InputError, match="another system") as err:
        _request(tmp_path / "paper", system="highwind", start=out)
    assert START_FILE in str(err.value)
    with pytest.raises(InputError, match="no start file"):
        _request(tmp_path / "none", start=tmp_path)


def test_the_sweep_says_what_its_solves_cost(first):
    out, done = first
    # one scenario, solved once: its final solve is all the sweep ran
    its = done.iterations
    assert its["reported"] == int(done.summary["iterations"].sum()) == its["all"] > 0
    assert its["intermediate_points"] == its["intermediate_iterations"] == 0
    from reports.optimization_section import run_rows

    manifest = json.loads((out / "manifest.json").read_text())
    rows = dict(run_rows(manifest, None))
    assert rows["IPOPT iterations"].startswith(f"{its['reported']} in the scenarios' final")
    assert rows["option start_file"] == "not set"
