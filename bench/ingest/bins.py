"""Bin sums of a streamed time series: 0.1 s (or one sample interval) bins on a regular
grid, gaps in the time axis, and the bin means the alignment and the steady-state
detection work on."""

from __future__ import annotations

import math

import numpy as np

from bench.ingest import steady
from kernel.units import RPM_PER_RAD_S


class StreamBins:
    """Growing per-bin sums on a grid ``t0 + k * dt`` (time sorted, so bins are runs).

    The bin width and the gap threshold follow the stream's median sample
    interval, taken from its first chunk (:func:`steady.bin_width_s`,
    :func:`steady.gap_threshold_s`); the grid starts half a sample interval
    before the first sample, so a regular logger puts its samples mid-bin.
    Gaps are kept as bin ranges ``[first empty bin, first bin after the gap]``.

    Parameters
    ----------
    config : SteadyConfig
        Gives the narrowest bin and the gap factor.
    extra : tuple of str
        Further per-sample quantities whose bin means are wanted (``p_elec``,
        ``p_mech_logged`` of a single-stream log); each has its own valid count.
        Their bin means come out under the same names.
    """

    BASE = ("rows", "valid", "speed", "torque")

    def __init__(self, config: steady.SteadyConfig, extra: tuple[str, ...] = ()) -> None:
        self.config = config
        self.extra = extra
        self.fields = self.BASE + extra + tuple(f"{q}_n" for q in extra)
        self.dt = config.bin_s
        self.interval_s = math.nan
        self.gap_s = math.inf
        self.t0: float | None = None
        self.last_t = math.nan
        self.gaps: list[np.ndarray] = []
        self.sums = {f: np.zeros(0) for f in self.fields}

    def _start(self, t: np.ndarray) -> None:
        d = np.diff(t[:100_000])
        self.interval_s = float(np.median(d)) if d.size else math.nan
        self.dt = steady.bin_width_s(self.interval_s, self.config)
        if d.size:
            self.gap_s = steady.gap_threshold_s(self.interval_s, self.config)
        half = 0.5 * min(self.dt, self.interval_s) if d.size else 0.0
        self.t0 = float(t[0]) - half

    def add(self, t: np.ndarray, speed: np.ndarray, torque: np.ndarray, **extra) -> None:
        """Add a chunk of sorted times [s] and drum-frame speed [rpm] and torque [N m]
        (and the ``extra`` quantities by name)."""
        if self.t0 is None:
            self._start(t)
        k = ((t - self.t0) / self.dt).astype(np.int64)
        jumps = np.flatnonzero(np.diff(t, prepend=self.last_t) > self.gap_s)
        if jumps.size:
            after = k[jumps]
            before = k[np.maximum(jumps - 1, 0)]
            if jumps[0] == 0:  # the gap lies between the last chunk and this one
                before[0] = int((self.last_t - self.t0) / self.dt)
            self.gaps.append(np.column_stack((before + 1, after)))
        self.last_t = float(t[-1])
        starts = np.concatenate(([0], np.flatnonzero(np.diff(k)) + 1))
        ids = k[starts]
        n = int(ids[-1]) + 1
        if n > self.sums["rows"].size:
            size = max(n, self.sums["rows"].size + self.sums["rows"].size // 4)
            for f in self.fields:
                grown = np.zeros(size)
                grown[: self.sums[f].size] = self.sums[f]
                self.sums[f] = grown
        ok = np.isfinite(speed) & np.isfinite(torque)
        self.sums["rows"][ids] += np.diff(np.append(starts, t.size))
        self.sums["valid"][ids] += np.add.reduceat(ok, starts, dtype=np.int64)
        for f, x in (("speed", speed), ("torque", torque)):
            self.sums[f][ids] += np.add.reduceat(np.where(ok, x, 0.0), starts)
        for f in self.extra:
            x = extra[f]
            fin = np.isfinite(x)
            self.sums[f][ids] += np.add.reduceat(np.where(fin, x, 0.0), starts)
            self.sums[f + "_n"][ids] += np.add.reduceat(fin, starts, dtype=np.int64)

    def means(self, n_bins: int, torque_offset_nm: float = 0.0) -> dict[str, np.ndarray]:
        """Bin means of speed and torque (less ``torque_offset_nm``), their product as
        ``p_mech`` [W], the extra quantities, the valid fraction (NaN for empty bins)
        and ``cuts`` (True for the bins of a gap and the first bin after it; a
        gap is a hole in the time axis or a run of bins without a valid sample,
        each longer than the gap threshold)."""
        valid = self.sums["valid"][:n_bins]
        rows = self.sums["rows"][:n_bins]
        with np.errstate(invalid="ignore", divide="ignore"):
            out = {f: self.sums[f][:n_bins] / valid for f in ("speed", "torque")}
            out["torque"] = out["torque"] - torque_offset_nm
            out["valid_frac"] = np.where(rows > 0, valid / rows, np.nan)
            for f in self.extra:
                out[f] = self.sums[f][:n_bins] / self.sums[f + "_n"][:n_bins]
        # product of bin means: enough for the alignment; points use exact sample means
        out["p_mech"] = out["speed"] * out["torque"] / RPM_PER_RAD_S
        # runs of bins without a valid sample longer than the gap threshold are gaps too
        edges = np.diff(np.concatenate(([0], (valid == 0).astype(np.int8), [0])))
        r0, r1 = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        long = (r1 - r0) * self.dt > self.gap_s
        marks = np.zeros(n_bins + 1, np.int64)
        for g in [*self.gaps, np.column_stack((r0[long], r1[long]))]:
            np.add.at(marks, np.minimum(g[:, 0], n_bins), 1)
            np.add.at(marks, np.minimum(g[:, 1] + 1, n_bins), -1)
        out["cuts"] = np.cumsum(marks[:-1]) > 0
        return out

    @property
    def n_gaps(self) -> int:
        """Gaps found so far."""
        return sum(g.shape[0] for g in self.gaps)
