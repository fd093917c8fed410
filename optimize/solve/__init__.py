"""Solving the problem: homotopy cold start, stored initial guess, warm solves, results."""
