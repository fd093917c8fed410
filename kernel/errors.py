"""Errors that carry the place of a bad input, so the CLI can name it."""

from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    """Bad user input: a file, a line or column within it, and what was expected.

    Parameters
    ----------
    path : str or Path or None
        The offending file (or directory).
    problem : str
        What is wrong, in plain words.
    line : int, optional
        1-based line number in the file, when known.
    column : str, optional
        Column name (or 1-based column index as text), when known; a command-line option
        (``--scenario``) when the value came from one, said as "option --scenario".
    expected : str, optional
        What the tool expected instead.
    """

    def __init__(
        self,
        path: str | Path | None,
        problem: str,
        *,
        line: int | None = None,
        column: str | None = None,
        expected: str | None = None,
    ) -> None:
        self.path = None if path is None else Path(path)
        self.problem = problem
        self.line = line
        self.column = column
        self.expected = expected
        super().__init__(self.describe())

    def describe(self) -> str:
        """Return one human-readable line: ``file:line: column 'x': problem; expected ...``.

        Without a file (a command-line option), the problem comes first: it names the
        option itself (``--wind-grid 7: ...``).
        """
        parts = [] if self.path is None else [str(self.path)]
        if self.path is not None and self.line is not None:
            parts[0] += f":{self.line}"
        if self.column is not None:  # a command-line option is an option, not a column
            parts.append(f"option {self.column}" if str(self.column).startswith("--")
                         else f"column {self.column!r}")
        msg = ": ".join([*parts, self.problem])
        if self.expected:
            msg += f"; expected {self.expected}"
        return msg
