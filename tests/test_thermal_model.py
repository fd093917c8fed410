"""kernel.thermal_model.ThermalModel: the power model's ``thermal`` block typed, written back
key for key (the file and its SHA-256 unchanged), carried by the similarity law, and the
network the OCP flies."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import pytest

from kernel.thermal_model import ThermalModel
from optimize.door import paper_model

#: a two-node block in the order and with the keys bench fit writes (docs/schemas.md §3)
BLOCK = {
    "version": 2, "nodes": 2, "model": "theta = ambient_c + sum_i theta_i ...",
    "r_th_k_per_w": 0.05, "r_th_k_per_w_ci95": [0.048, 0.052],
    "tau_th_s": 400.0, "tau_th_s_ci95": [380.0, 420.0],
    "c_th_j_per_k": 8000.0, "c_th_j_per_k_ci95": [7600.0, 8400.0],
    "modes": [{"r_k_per_w": 0.01, "r_k_per_w_ci95": [0.009, 0.011], "tau_s": 20.0,
               "tau_s_ci95": [18.0, 22.0]},
              {"r_k_per_w": 0.04, "r_k_per_w_ci95": [0.038, 0.042], "tau_s": 600.0,
               "tau_s_ci95": [570.0, 630.0]}],
    "ladder": [{"node": "winding", "c_j_per_k": 1500.0, "c_j_per_k_ci95": [1400.0, 1600.0],
                "r_k_per_w": 0.015, "r_k_per_w_ci95": [0.014, 0.016]},
               {"node": "housing", "c_j_per_k": 20000.0, "c_j_per_k_ci95": [19000.0, 21000.0],
                "r_k_per_w": 0.035, "r_k_per_w_ci95": [0.034, 0.036]}],
    "copper_temp_coeff_per_k": 0.0039, "copper_temp_coeff_per_k_ci95": [0.0035, 0.0043],
    "theta_ref_c": 20.0, "theta_points_c": 57.0, "ambient_c": 21.8,
    "session_ambient_c": {"motor_01": 21.6, "generator_01": 22.0},
    "aux_load": {"theta_ref_c": 20.0, "knots_c": [30.0, 40.0], "linear_w_per_k": 0.5,
                 "hinge_w_per_k": [1.0, 2.0]},
    "selection": {"rule": "one-SE", "unit": "session", "chosen_nodes": 2, "fitted_nodes": 2,
                  "candidates": []},
    "statistics": {"rms_k": 0.4, "n_bins": 100, "bin_s": 5.0},
    "sessions": ["generator_01", "motor_01"],
}


def test_the_block_is_written_back_key_for_key():
    """to_dict gives back the block read: the same keys in the same order, the same values
    (the intervals as lists), so the file and its hash do not change."""
    model = ThermalModel.from_dict(BLOCK)
    assert model.nodes == 2 and model.ladder[1].node == "housing"
    assert model.ci95["tau_th_s"] == (380.0, 420.0)
    out = model.to_dict()
    assert out == BLOCK and list(out) == list(BLOCK)
    assert [list(n) for n in out["ladder"]] == [list(n) for n in BLOCK["ladder"]]
    # an older block (one node, no network, an integer where a float is usual) as it was
    old = {"r_th_k_per_w": 0.05, "tau_th_s": 600, "c_th_j_per_k": 12000.0, "extra_key": [1]}
    assert json.dumps(ThermalModel.from_dict(old).to_dict()) == json.dumps(old)


def test_a_power_model_hashes_its_file():
    """A power model holding the typed block hashes the canonical JSON of the file's dict,
    the thermal block as written (the SHA-256 in every cache key is the file's)."""
    data = {**paper_model().to_dict(), "thermal": BLOCK}
    model = dataclasses.replace(paper_model(), thermal=BLOCK)
    assert isinstance(model.thermal, ThermalModel)
    canonical = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    assert model.sha256 == hashlib.sha256(canonical.encode()).hexdigest()


def test_carried_scales_resistances_and_capacities_by_the_loss_ratio():
    """s times the losses: every resistance / s, every capacity x s, their intervals too;
    time constants, the copper coefficient and the temperatures kept; the law recorded."""
    s = 2.5
    carried = ThermalModel.from_dict(BLOCK).carried(s, "the law").to_dict()
    assert carried["r_th_k_per_w"] == pytest.approx(0.05 / s, rel=1e-15)
    assert carried["r_th_k_per_w_ci95"] == pytest.approx([0.048 / s, 0.052 / s], rel=1e-15)
    assert carried["c_th_j_per_k"] == pytest.approx(8000.0 * s, rel=1e-15)
    for got, base in zip(carried["ladder"], BLOCK["ladder"], strict=True):
        assert got["r_k_per_w"] == pytest.approx(base["r_k_per_w"] / s, rel=1e-15)
        assert got["c_j_per_k_ci95"] == pytest.approx([v * s for v in base["c_j_per_k_ci95"]],
                                                      rel=1e-15)
    for got, base in zip(carried["modes"], BLOCK["modes"], strict=True):
        assert got["r_k_per_w"] == pytest.approx(base["r_k_per_w"] / s, rel=1e-15)
        assert got["tau_s"] == base["tau_s"] and got["tau_s_ci95"] == base["tau_s_ci95"]
    kept = ("tau_th_s", "tau_th_s_ci95", "copper_temp_coeff_per_k", "theta_ref_c",
            "theta_points_c", "ambient_c", "aux_load", "selection", "sessions")
    assert {k: carried[k] for k in kept} == {k: BLOCK[k] for k in kept}
    assert carried["carried"] == {"power_ratio": s, "law": "the law"}


def test_the_network_the_ocp_flies():
    """One node: (r_th, tau_th); more: each node's resistance outwards and r c; more nodes
    without their ladder is refused by name."""
    one = ThermalModel.from_dict({"nodes": 1, "r_th_k_per_w": 0.05, "tau_th_s": 600.0,
                                  "c_th_j_per_k": 12000.0})
    assert one.network() == ((0.05, 600.0),) and one.mode_figures() == ((0.05, 600.0),)
    two = ThermalModel.from_dict(BLOCK)
    assert two.network() == ((0.015, 0.015 * 1500.0), (0.035, 0.035 * 20000.0))
    assert two.mode_figures() == ((0.01, 20.0), (0.04, 600.0))
    bare = ThermalModel.from_dict({k: v for k, v in BLOCK.items() if k != "ladder"})
    with pytest.raises(ValueError, match="2 nodes but no 'ladder'"):
        bare.network()
    with pytest.raises(ValueError, match="no 'c_th_j_per_k'"):
        ThermalModel.from_dict({"r_th_k_per_w": 0.05, "tau_th_s": 600.0})
