"""Every start of a solve, in one place.

A solve starts from one of:

* its parts' own guesses (:mod:`optimize.solve.starts.fill`): each part fills the
  variables it owns, along the start trajectory of the parts before it (the kite's
  circular loop, :func:`optimize.problem.guess.circular_loop`, is the kite part's);
* the homotopy from those guesses (:mod:`optimize.solve.starts.homotopy`), a cold start;
* the shipped solution (:mod:`optimize.solve.starts.stored_guess`), when it fits the OCP;
* :func:`optimize.solve.starts.cold.start`: the shipped solution, else the homotopy;
* a neighbouring optimum (:func:`optimize.solve.solve.solve`: the warm start), moved
  along its tangent in the scenario's parameters when the solver options ask for it
  (:mod:`optimize.solve.starts.predictor`; off by default, benchmarks/README.md);
* an optimum on a coarser mesh interpolated onto a finer one
  (:mod:`optimize.solve.starts.remesh`);
* a converged cycle kept only as its trajectory (:mod:`optimize.solve.starts.cycle`).

Which start each solve of a sweep gets is the solve service's choice
(:mod:`optimize.service`).
"""
