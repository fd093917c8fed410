"""``bench cycle``: fly an optimal cycle on the bench and verify its prediction.

``export`` turns a converged scenario of an optimize folder into a drive profile a bench
controller runs (:mod:`bench.cycle_profile`); ``verify`` compares the cycles a cycle-run
session stored (``bench ingest``) with the power model's and the optimizer's prediction.
"""
