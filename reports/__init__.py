"""drivebench stage package: the self-contained HTML report (``bench report``).

The report only reads the files the other stages write (docs/schemas.md §2-§5):

- :mod:`reports.inputs`: reading those files, recording their hashes and what is missing;
- :mod:`reports.sections`: campaign, efficiency map and power-model sections;
- :mod:`reports.optimization`: the optimized cycles (Table II, Figs. 8, 9, 10, 3, claims);
- :mod:`reports.provenance`: package versions, input hashes, command lines, date;
- :mod:`reports.drive_figures`, :mod:`reports.cycle_figures`: the figures, as inline SVG
  (:mod:`reports.svg`);
- :mod:`reports.render`: Jinja2 (autoescape on) and the atomic write; :mod:`reports.cli`.
"""
