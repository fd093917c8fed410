"""drivebench stage package: fitting (``bench fit``).

From the store's operating points to the drive's electrical power model:

- :mod:`fitting.points`: read and check ``<store>/points/*.parquet``;
- :mod:`fitting.efficiency`: paper eqs. (1)-(2), masking rules, gridded map (Fig. 5);
- :mod:`fitting.domain`: measured envelope per quadrant (validity domain);
- :mod:`fitting.terms`: term lists (eq. 4, full polynomials, the paper's w^6 T^4 space);
- :mod:`fitting.power_fit`: (weighted) least squares with statistics;
- :mod:`fitting.selection`: k-fold CV RMSE + BIC, quadrant weighting, extra-terms check;
- :mod:`fitting.power_model` (evaluation; :mod:`fitting.power_model_casadi` for the OCP),
  :mod:`fitting.model_schema` (validation), :mod:`fitting.model_file` (reading, writing):
  the versioned ``power_model.json`` (docs/schemas.md §3);
- :mod:`fitting.loss_table`, :mod:`fitting.figures`, exports;
- :mod:`fitting.pipeline`: all of it as one call; :mod:`fitting.cli`: ``bench fit``.
"""
