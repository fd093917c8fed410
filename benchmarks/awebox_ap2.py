"""awebox's own AP2 example, run with and without its sideslip penalty (issue 39).

The reference for ``benchmarks/ap2_ablation.py``: awebox (github.com/awebox/awebox,
commit 03adf95, 2025-09-16) flies its AP2 example (``examples/ampyx_ap2_trajectory.py``
with ``awebox/opts/kite_data/ampyx_ap2_settings.py``; Licitra et al., Energy 173,
2019) with ``nlp.cost.beta = True``: a penalty of ``1e3 / n_k`` times the integral of the
squared sideslip [rad^2 s] in an objective whose power term is the average power over
awebox's power estimate. Its example had ``nlp.cost.beta = False`` and expected 4.7 kW
and 35.0 s until commit aad2a34 (2025-08-26), which turned the penalty on and set the
expectation to the paper's 4.4 kW and 39.6 s. This script runs the example's settings
as they ship (MUMPS, since HSL is absent) with the penalty on (``--beta``) or off, and
prints the average power, the period, the largest sideslip along awebox's interpolated
output and the penalty's scale (awebox's characteristic power, from which the
penalty's weight in watts follows).

awebox is not a dependency of drivebench: run this with a Python that has it::

    git clone https://github.com/awebox/awebox && git -C awebox checkout 03adf95
    python3 -m venv awe && awe/bin/pip install casadi==3.6.4 'numpy<2' 'matplotlib<3.9' \\
        scipy pandas tabulate progress jinja2 reportlab joblib && awe/bin/pip install -e awebox
    awe/bin/python benchmarks/awebox_ap2.py --beta
    awe/bin/python benchmarks/awebox_ap2.py

Each run prints one JSON line (and writes it with ``--out FILE``).
"""

from __future__ import annotations

import argparse
import json
import time

#: awebox's AP2 example as it ships (examples/ampyx_ap2_trajectory.py at 03adf95), HSL
#: replaced by MUMPS and nothing plotted
EXAMPLE = {
    "user_options.system_model.architecture": {1: 0},
    "user_options.trajectory.type": "power_cycle",
    "user_options.trajectory.system_type": "lift_mode",
    "user_options.trajectory.lift_mode.windings": 1,
    "params.wind.z_ref": 100.0,
    "params.wind.power_wind.exp_ref": 0.15,
    "user_options.wind.model": "power",
    "user_options.wind.u_ref": 10.0,
    "nlp.n_k": 40,
    "nlp.collocation.u_param": "zoh",
    "user_options.trajectory.lift_mode.phase_fix": "simple",
    "solver.linear_solver": "mumps",
    "nlp.compile_subfunctions": False,
}


def options(beta: bool) -> dict:
    """The example's options with the sideslip penalty on or off."""
    from awebox.opts.kite_data import ampyx_ap2_settings

    opts = ampyx_ap2_settings.set_ampyx_ap2_settings(
        {"user_options.system_model.architecture": {1: 0}})
    return {**opts, **EXAMPLE, "nlp.cost.beta": beta}


def penalty_scale(trial) -> dict:
    """awebox's characteristic power [W] (its energy scaling over the power cost's time
    estimate: the power term is ``-P_avg / P_char``) and the sideslip penalty's weight
    ``P_char * cost.beta / normalization.beta`` [W / (rad^2 s)] on ``int beta^2 dt``."""
    o = trial.options
    p_char = o["model"]["scaling"]["x"]["e"] / o["solver"]["cost"]["power"][1]
    weight = o["solver"]["cost"]["beta"][0] / o["nlp"]["cost"]["normalization"]["beta"]
    return {"p_char_w": float(p_char), "beta_weight_w_per_rad2_s": float(p_char * weight)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--beta", action="store_true", help="with awebox's sideslip penalty "
                    "(as its example ships since aad2a34)")
    ap.add_argument("--out", help="also write the JSON line to this file")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import awebox as awe
    import numpy as np

    t0 = time.perf_counter()
    trial = awe.Trial(options(args.beta), "Ampyx_AP2")
    trial.build()
    t1 = time.perf_counter()
    trial.optimize()
    t2 = time.perf_counter()
    pd = trial.visualization.plot_dict
    beta_deg = np.degrees(pd["outputs"]["aerodynamics"]["beta1"][0])
    out = {"beta_penalty": args.beta,
           "avg_power_kw": float(pd["power_and_performance"]["avg_power"] / 1e3),
           "period_s": float(pd["time_grids"]["ip"][-1]),
           "max_abs_sideslip_deg": float(np.max(np.abs(beta_deg))),
           "reel_speed_m_s": [float(np.min(pd["x"]["dl_t"][0])),
                              float(np.max(pd["x"]["dl_t"][0]))],
           **penalty_scale(trial), "build_s": t1 - t0, "solve_s": t2 - t1}
    line = json.dumps(out)
    print(line)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as f:
            f.write(line + "\n")


if __name__ == "__main__":
    main()
