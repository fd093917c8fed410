"""``bench synth``: deterministic synthetic bench campaigns with a documented truth.

Modules, one concept each:

- :mod:`loss_model`: the true drive power ``true_p_elec_w(speed_rpm, torque_nm, theta_c,
  model)``, the thermal step, the paper's quadratic fit and its calibration.
- :mod:`plan`: the campaign's sessions (:data:`plan.CAMPAIGN`) and their operating points.
- :mod:`true_signals`: step timing, transients, winding temperature, true signals and
  steady-window means.
- :mod:`instruments`: what the DAQ, the power analyzer and the bench software log.
- :mod:`numfmt`, :mod:`writers`: fast deterministic CSV text, TDMS, atomic writes.
- :mod:`session_files`: one session's files (session.toml, DAQ, analyzer, point table).
- :mod:`campaign`: ``generate(out_dir, seed, scale)`` and ``is_complete(out_dir, seed, scale)``.
- :mod:`readme`, :mod:`cli`: the campaign README and the ``bench synth`` command.
- :mod:`exports`: foreign bench exports with a known truth for the mapping features (a
  dyno table in N mm with title lines; an EV bench's 500-column export with ``expr``/``sum``).
"""
