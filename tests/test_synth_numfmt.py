"""The vectorized number formatter against Python's own float formatting and parsing."""

import numpy as np

from bench.synth.numfmt import format_rows


def test_simple_values_read_like_printf():
    x = np.array([0.0, 1.5, -1234.5678, 99.9951, 100000.0, -0.0004, 7.0])
    got = format_rows([x, np.arange(7)], [3, 0]).decode().splitlines()
    want = [f"{v:.3f},{i}" for i, v in enumerate(x)]
    want[5] = "0.000,5"  # a value that rounds to zero is written without a sign
    assert got == want


def test_random_values_parse_back_within_half_a_digit():
    rng = np.random.default_rng(0)
    cols = [rng.normal(0, 10.0**k, 20_000) for k in (0, 2, 4)]
    decimals = [4, 2, 0]
    text = format_rows(cols, decimals, sep=";", decimal_mark=",").decode()
    rows = [line.split(";") for line in text.splitlines()]
    assert len(rows) == 20_000
    for j, (col, d) in enumerate(zip(cols, decimals, strict=True)):
        back = np.array([float(r[j].replace(",", ".")) for r in rows])
        # rounding to d decimals moves a value by at most half a unit of the last digit
        assert np.max(np.abs(back - col)) <= 0.5 * 10.0**-d * (1 + 1e-9)
        if d == 0:
            assert not any("," in r[j] for r in rows)


def test_markers_replace_cells():
    x = np.array([1.0, 2.0, 3.0])
    markers = {1: (np.array([0, 2]), np.array([1, 0]), ["9.91E+37", "NAN"])}
    text = format_rows([x, x], [1, 2], markers=markers).decode()
    assert text == "1.0,NAN\n2.0,2.00\n3.0,9.91E+37\n"
