"""The failed scenarios of a sweep, each with its status and why: a failed sweep is data.

A scenario fails when its solver did not converge (its status says how) or when its
converged optimum failed the result check (``result_check``,
:mod:`optimize.analysis.result_check`). Read from ``summary.parquet``; the columns
other than ``scenario``, ``success`` and ``status`` are read where present.
"""

from __future__ import annotations

import pandas as pd


def failure_text(row) -> str:
    """``"<status>"``, with ``"; result check failed"`` when the solver converged."""
    check = str(row.get("result_check", "") or "")
    return f"{row['status']}; result check failed" if check.startswith("failed") \
        else str(row["status"])


def failed_rows(summary: pd.DataFrame) -> list[dict]:
    """One dict per failed scenario: ``scenario``, ``status``, ``reason`` (plain strings)."""
    rows = []
    for r in summary.to_dict(orient="records"):
        if not bool(r.get("success")):
            check = str(r.get("result_check", "") or "")
            rows.append({"scenario": str(r["scenario"]), "status": str(r["status"]),
                         "reason": check if check.startswith("failed") else
                         "the solver did not converge"})
    return rows
