"""The winding's thermal network (fitting/thermal_network.py) and how many nodes the
logs support (fitting/thermal_selection.py), against ladders simulated independently
(bench/synth/thermal_ladder.py: matrix exponentials of the node equations, not the
fit's mode sums)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.synth.thermal_ladder import heat_steps, ladder_matrices, winding_bin_means
from fitting.thermal_network import fit_network, ladder_of, mean_time_constant_s
from fitting.thermal_selection import select_nodes

BIN_S = 5.0
#: a two-node truth: winding 2 kJ/K, 0.02 K/W to a 20 kJ/K housing, 0.04 K/W to ambient
TWO_NODES = ((2000.0, 0.02), (20000.0, 0.04))
#: a one-node truth with the same steady resistance
ONE_NODE = ((36000.0, 0.06),)


def modes_of_ladder(ladder) -> np.ndarray:
    """The ladder's Foster modes from the eigen-decomposition of its node equations."""
    a, b = ladder_matrices(ladder)
    lam, v = np.linalg.eig(a)
    residue = (v[0, :] * np.linalg.solve(v, b)).real
    tau = -1.0 / lam.real
    return np.column_stack([residue * tau, tau])[np.argsort(tau)]


def session(ladder, rng, hours: float, ambient_c: float, noise_k: float = 0.2) -> dict:
    """A logged session: heat steps of 1-5 min (0-1500 W), the winding's bin means,
    sensor noise."""
    steps = heat_steps(rng, int(hours * 3600 / BIN_S))
    theta = ambient_c + winding_bin_means(ladder, steps, BIN_S)
    return {"heat_w": steps, "theta_c": theta + rng.normal(0, noise_k, steps.size),
            "bin_s": BIN_S}


def campaign(ladder, sessions: int = 3, hours: float = 2.0) -> dict[str, dict]:
    rng = np.random.default_rng(7)
    return {f"s{i}": session(ladder, rng, hours, 20.0 + 2.5 * i) for i in range(sessions)}


def test_the_ladder_of_a_foster_network_is_the_simulated_one():
    for ladder in (TWO_NODES, ONE_NODE, ((500.0, 0.01), (4000.0, 0.03), (60000.0, 0.02))):
        got = ladder_of(modes_of_ladder(ladder))
        np.testing.assert_allclose(got, np.array(ladder), rtol=1e-8)
    modes = modes_of_ladder(TWO_NODES)
    a, b = ladder_matrices(TWO_NODES)
    # the mean time constant is -Z'(0) / Z(0) of the node equations
    assert mean_time_constant_s(modes) == pytest.approx(
        (np.linalg.solve(a, np.linalg.solve(a, b)))[0] / (-np.linalg.solve(a, b)[0]),
        rel=1e-10)


def test_two_nodes_are_chosen_and_recovered_where_the_logs_show_them():
    series = campaign(TWO_NODES)
    selection = select_nodes(series)
    assert selection["unit"] == "session" and selection["chosen_nodes"] == 2
    one, two = selection["candidates"]
    assert two["cv_rms_k"] < one["cv_rms_k"] - one["cv_rms_k_se"]
    fit = fit_network(series, 2)
    np.testing.assert_allclose(ladder_of(fit["modes"]), np.array(TWO_NODES), rtol=0.10)
    for k, sid in enumerate(series):  # every session's ambient
        assert fit["ambient_c"][sid] == pytest.approx(20.0 + 2.5 * k, abs=0.3)


def test_one_node_is_kept_where_the_logs_show_one():
    series = campaign(ONE_NODE)
    assert select_nodes(series)["chosen_nodes"] == 1
    fit = fit_network(series, 1)
    np.testing.assert_allclose(ladder_of(fit["modes"]), np.array(ONE_NODE), rtol=0.05)


def test_a_single_session_is_cross_validated_in_blocks():
    series = campaign(TWO_NODES, sessions=1, hours=4.0)
    selection = select_nodes(series)
    assert selection["unit"] == "block"
    assert [len(c["held_out_rms_k"]) for c in selection["candidates"]] == [3, 3]
    assert selection["chosen_nodes"] == 2
