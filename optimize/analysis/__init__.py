"""Analysis of sweep results: the comparison with the paper (not part of the solver)."""
