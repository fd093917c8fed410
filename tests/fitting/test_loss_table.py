"""Loss table export: hand-calculated cells, layout, units in the header."""

import math

import numpy as np
import pytest

from fitting.loss_table import read_loss_table, write_loss_table
from optimize.paper_model import paper_model


def test_loss_table_of_the_paper_model(tmp_path):
    model = paper_model()
    path = write_loss_table(model, tmp_path / "loss_table.csv")
    speeds, torques, losses = read_loss_table(path)
    # the paper model's domain is the rated box: 100 rpm x 2 N m breakpoints
    np.testing.assert_array_equal(speeds, np.arange(-1500, 1501, 100))
    np.testing.assert_array_equal(torques, np.arange(0, 79, 2))
    a0, a1, a2, a3 = 293.5816373499238, 0.0003931623408, 0.0665919381751, 0.1078628659825
    for s, t in ((-1500, 78), (1500, 78), (0, 0), (-500, 40)):
        p_elec = a0 + a1 * s**2 + a2 * t**2 + a3 * s * t  # docs/paper_figures.md §1 by hand
        p_mech = s * 2 * math.pi / 60 * t
        i, j = np.flatnonzero(speeds == s)[0], np.flatnonzero(torques == t)[0]
        # cells are written with 3 decimals
        assert losses[i, j] == pytest.approx(p_elec - p_mech, abs=1e-3)
    # docs/paper_figures.md §1: at -1500 rpm, 78 N m the drive loses 12.25 - 11.04 = 1.21 kW
    assert losses[0, -1] == pytest.approx(1215.6, abs=1.0)
    header = [ln for ln in path.read_text().splitlines() if ln.startswith("#")]
    text = "\n".join(header)
    assert "[W]" in text and "[rpm]" in text and "[N m]" in text and model.sha256 in text
    # every cell of the rated box lies in the paper model's domain
    assert "0.0 % of the cells lie outside" in text
