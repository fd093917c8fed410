"""Sweeps of many scenarios: plan, warm-start chains, executors, trust checks, files."""
