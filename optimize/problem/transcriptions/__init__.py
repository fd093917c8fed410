"""The transcriptions of the cycle OCP, one object per method, chosen once.

* :mod:`.structure`: a transcribed NLP's named decision vector, index bookkeeping and
  per-point structure;
* :mod:`.layouts`: direct Radau collocation into one scaled NLP, in the general layout
  or in stages (fatrop's);
* :mod:`.derivatives`: that NLP's derivatives point by point, in each solver's format;
* :mod:`.collocation`: the collocation method (:class:`.collocation.CollocationMethod`);
* :mod:`.condensed_nlp`, :mod:`.condensed_derivatives`, :mod:`.condensed_multipliers`,
  :mod:`.condensed`: the condensed method (multiple shooting with each interval's
  collocation solved inside it) and how its starts and solutions cross to the
  collocation's layout;
* :mod:`.codegen`: the repeated functions as compiled C code;
* :mod:`.method`: the interface every method implements.

:func:`method_of` maps the solver options' ``transcription`` to its method; no other
code compares the option with a method's name.
"""

from __future__ import annotations

from optimize.problem.options import TRANSCRIPTIONS, SolverOptions
from optimize.problem.transcriptions.collocation import CollocationMethod
from optimize.problem.transcriptions.condensed import CondensedMethod
from optimize.problem.transcriptions.method import Method

#: the method of each transcription name (:data:`optimize.problem.options.TRANSCRIPTIONS`)
METHODS: dict[str, Method] = {m.name: m for m in (CollocationMethod(), CondensedMethod())}
if set(METHODS) != set(TRANSCRIPTIONS):
    raise ImportError(f"transcription methods {sorted(METHODS)} are not the options' "
                      f"{sorted(TRANSCRIPTIONS)}")


def method_of(solver: SolverOptions) -> Method:
    """The transcription method of the solver options."""
    return METHODS[solver.transcription]
