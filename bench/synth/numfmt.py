"""Fast, deterministic text formatting of numeric tables (vectorized, no per-row Python).

Each value becomes fixed-point text with a chosen number of decimals and decimal
mark; a byte matrix holds one row per line with zero bytes as padding, and the
padding is squeezed out at the end. This writes tens of millions of CSV rows in
seconds and gives byte-identical output for identical input, whatever the platform's
``printf``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

_ZERO = ord("0")


def _fixed_point(values: np.ndarray, decimals: int, decimal_mark: bytes) -> np.ndarray:
    """Byte matrix (rows x width) of ``values`` as ``[-]digits[.digits]``, 0 = padding."""
    x = np.asarray(values, dtype=float)
    x = np.where(np.isfinite(x), x, 0.0)
    v = np.rint(np.abs(x) * 10.0**decimals).astype(np.int64)
    n_digits = max(decimals + 1, len(str(int(v.max()))) if v.size else 1)
    width = 1 + n_digits + (1 if decimals else 0)
    out = np.zeros((v.size, width), dtype=np.uint8)
    out[:, 0] = np.where((x < 0) & (v != 0), ord("-"), 0)
    rem, col = v, width - 1
    for pos in range(n_digits):  # least significant digit first
        rem, digit = np.divmod(rem, 10)
        out[:, col] = digit + _ZERO
        col -= 1
        if pos == decimals - 1:
            out[:, col] = decimal_mark[0]
            col -= 1
    # blank the leading zeros of the integer part (its last digit always stays)
    n_int = n_digits - decimals
    int_part = v // 10**decimals
    for j in range(n_int - 1):
        out[int_part < 10 ** (n_int - 1 - j), 1 + j] = 0
    return out


def format_rows(
    columns: Sequence[np.ndarray],
    decimals: Sequence[int],
    *,
    sep: str = ",",
    decimal_mark: str = ".",
    markers: dict[int, tuple[np.ndarray, np.ndarray, Sequence[str]]] | None = None,
) -> bytes:
    """Format columns into CSV lines (``\\n`` terminated).

    Parameters
    ----------
    columns : sequence of numpy.ndarray
        Equal-length numeric columns.
    decimals : sequence of int
        Digits after the decimal mark per column (0: integer, no mark).
    sep : str
        One-character field separator.
    decimal_mark : str
        One-character decimal mark (``"."`` or ``","``).
    markers : dict, optional
        ``{column index: (rows, codes, strings)}``: the cell of each row in ``rows``
        is written as ``strings[code]`` instead of its number (invalid-value markers).

    Returns
    -------
    bytes
        The lines, ASCII.
    """
    n = len(columns[0])
    if n == 0:
        return b""
    blocks = []
    for ci, (col, dec) in enumerate(zip(columns, decimals, strict=True)):
        block = _fixed_point(col, dec, decimal_mark.encode())
        if markers and ci in markers:
            rows, codes, strings = markers[ci]
            encoded = [s.encode() for s in strings]
            width = max(block.shape[1], max(len(s) for s in encoded))
            if width > block.shape[1]:
                pad = np.zeros((n, width - block.shape[1]), dtype=np.uint8)
                block = np.concatenate([block, pad], axis=1)
            table = np.zeros((len(encoded), width), dtype=np.uint8)
            for i, s in enumerate(encoded):
                table[i, : len(s)] = np.frombuffer(s, dtype=np.uint8)
            block[rows] = table[codes]
        if ci:
            blocks.append(np.full((n, 1), ord(sep), dtype=np.uint8))
        blocks.append(block)
    blocks.append(np.full((n, 1), ord("\n"), dtype=np.uint8))
    matrix = np.concatenate(blocks, axis=1)
    return matrix[matrix != 0].tobytes()
