"""The closing summary table of ``bench ingest``."""

from __future__ import annotations


def _fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def format_summary(ingested: list[str], unchanged: list[str], manifest: dict,
                   repaired=()) -> str:
    """One row per session of this run, then totals.

    Parameters
    ----------
    ingested, unchanged : list of str
        Session ids written / skipped (unchanged files) by this run.
    manifest : dict
        The store manifest after the run.
    repaired : collection of str
        Sessions re-ingested because their stored files were damaged (status
        ``repaired``).

    Returns
    -------
    str
        A plain-text table: session, status, kind, mode, points per quadrant,
        clock offset [s] and drift [ppm], torque-flange zero offset subtracted
        [N m] (``none`` without a tare), rejected windows by reason; then one line
        per session that gave no operating point saying why, and one per session
        without a tare saying why, and one per session ingested by this run with points
        kept with an efficiency outside [0, 1] (:func:`flag_lines`, manifest
        ``efficiency_flags``); a cycle run's kept cycles and one line
        per rejected cycle instead of its points.
    """
    head = ("session", "status", "kind", "mode", "motor", "generator", "offset_s", "drift_ppm",
            "zero_nm", "rejected")
    rows = []
    tot = {"motor": 0, "generator": 0}
    tot_rej: dict[str, int] = {}
    no_tare = []
    no_points = []
    cycle_runs: list[str] = []
    no_drift = []
    flagged: list[str] = []
    for sid in sorted(ingested + unchanged):
        e = manifest["sessions"][sid]
        q = e["points_per_quadrant"]
        for k in tot:
            tot[k] += q.get(k, 0)
        for r, n in e["rejected"].items():
            tot_rej[r] = tot_rej.get(r, 0) + n
        status = ("unchanged" if sid not in ingested else "repaired" if sid in repaired
                  else "ingested")
        rows.append(_row(sid, status, e))
        if e.get("kind") == "cycle_run":
            c = e.get("cycles") or {}
            cycle_runs.append(f"{sid}: {c.get('n_kept', 0)} of {c.get('n_profile_cycles', 0)} "
                              f"cycles of {c.get('scenario')} kept (period {c.get('period_s')} "
                              f"s, correlation {c.get('correlation')})")
            cycle_runs += [f"{sid}: rejected {n}" for n in c.get("notes", [])]
        elif e.get("n_points", 0) == 0:
            no_points.append(f"{sid}: {e.get('no_points_note', '0 points')}")
        if e.get("clock_drift_note"):
            no_drift.append(f"{sid}: {e['clock_drift_note']}")
        no_drift += [f"{sid}: temperature flagged: {n}" for n in e.get("temperature_notes", [])]
        flagged += flag_lines(sid, e.get("efficiency_flags") or (), sid in ingested)
        if e.get("torque_zero_offset_nm") is None:
            no_tare.append(f"{sid}: {e.get('torque_zero_note', 'no tare recorded')}")
    rows.append(("total", f"{len(ingested)} new", "", "", str(tot["motor"]),
                 str(tot["generator"]), "", "", "",
                 ", ".join(f"{r}: {n}" for r, n in sorted(tot_rej.items())) or "-"))
    notes = [f"NO POINTS from {n}" for n in no_points]
    notes += [f"cycle run {n}" for n in cycle_runs]
    notes += [f"no torque-flange tare, torque not zero-corrected: {n}" for n in no_tare]
    notes += no_drift
    notes += flagged
    return "\n".join([*_table(head, rows), *notes])


def flag_lines(sid: str, flags, ingested: bool) -> list[str]:
    """The summary's lines on a session's points with an efficiency outside [0, 1]: one
    line with the first one and the count of the others when ingested by this run, none
    for an unchanged session (said when it was ingested; all in the manifest)."""
    if not flags or not ingested:
        return []
    more = (f" and {len(flags) - 1} more (manifest efficiency_flags)" if len(flags) > 1
            else "")
    return [f"FLAGGED point: {sid}: {flags[0]}{more}"]


def _row(sid: str, status: str, e: dict) -> tuple[str, ...]:
    """One session's row of the table, from its manifest entry ``e``."""
    q = e["points_per_quadrant"]
    return (
        sid, status, e["kind"], e["mode"],
        str(q.get("motor", 0)), str(q.get("generator", 0)),
        _fmt(e.get("clock_offset_s"), ".4f"), _fmt(e.get("clock_drift_ppm"), ".1f"),
        "none" if e.get("torque_zero_offset_nm") is None
        else format(e["torque_zero_offset_nm"], ".3f"),
        ", ".join(f"{r}: {n}" for r, n in e["rejected"].items()) or "-",
    )


def _table(head: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    """The table's lines: head, rule, the sessions, rule, the total (the last row); numbers
    right-aligned."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
    right = {4, 5, 6, 7, 8}

    def line(cells) -> str:
        return "  ".join(c.rjust(w) if i in right else c.ljust(w)
                         for i, (c, w) in enumerate(zip(cells, widths, strict=True))).rstrip()

    sep = "  ".join("-" * w for w in widths)
    return [line(head), sep, *(line(r) for r in rows[:-1]), sep, line(rows[-1])]
