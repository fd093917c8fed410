"""Sweeps of many scenarios: plan (warm-start chains, run by :mod:`optimize.service`),
executors, trust checks, files."""
