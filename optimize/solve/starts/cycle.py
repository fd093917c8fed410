"""A start from a converged cycle kept only as its trajectory (``trajectories.parquet``)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from optimize.problem.ocp import Ocp
from optimize.solve.result import Solution


def solution_of_trajectory(ocp: Ocp, trajectory: pd.DataFrame) -> Solution:
    """A start of ``ocp`` at a cycle kept as its trajectory (the rows of
    :func:`trajectory_frame` on the same mesh, e.g. ``trajectories.parquet``'s of one
    scenario): the primal vector, with the cycle's start state its end state (periodic)
    and the fictitious forces zero (fixed there at every optimum); the multipliers zero,
    since the trajectory keeps none.

    Raises
    ------
    ValueError
        The trajectory has another number of points than the OCP's mesh.
    KeyError
        It lacks a variable of the model (named).
    """
    n, d = ocp.n_intervals, ocp.coll.degree
    traj = trajectory.sort_values("time_s")
    if len(traj) != n * d:
        raise ValueError(f"the trajectory has {len(traj)} points; the OCP's mesh {n} x {d}")

    def rows(names: tuple[str, ...]) -> np.ndarray:
        return np.vstack([traj[name].to_numpy(float) for name in names])

    dae = ocp.dae
    x = rows(dae.states.names)
    w = ocp.pack(np.hstack([x[:, -1:], x]), rows(dae.algebraic.names),
                 rows(dae.controls.names)[:, ::d],
                 np.zeros((dae.fictitious.size, ocp.layout.n_coll)),
                 float(traj["time_s"].iloc[-1]))
    return Solution(w=w, lam_x=np.zeros(ocp.layout.n_w), lam_g=np.zeros(ocp.layout.n_g),
                    n_intervals=n, degree=d)
