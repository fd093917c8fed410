"""A wall-time limit for a solver that has none of its own (fatrop on the collocation).

The solver evaluates the constraint Jacobian once per iterate. :class:`Gated` evaluates a
CasADi function as it is, copy-free, until the calling thread's deadline
(:mod:`optimize.problem.deadline`), and past it fails with a return flag, nothing
computed: the solver's call ends there in silence (an exception raised in a Python
callback is printed by CasADi, with every input of every enclosing function).
"""

from __future__ import annotations

import casadi as ca

from optimize.problem.deadline import passed


class Wrapped(ca.Callback):
    """A CasADi callback with the signature of a CasADi function ``fn`` (its inputs' and
    outputs' number, names and sparsities); a subclass says how it evaluates and calls
    ``self.construct(fn.name(), {})`` once its own attributes are set."""

    def __init__(self, fn: ca.Function) -> None:
        ca.Callback.__init__(self)
        self._fn = fn

    def get_n_in(self) -> int:
        return self._fn.n_in()

    def get_n_out(self) -> int:
        return self._fn.n_out()

    def get_name_in(self, i: int) -> str:
        return self._fn.name_in(i)

    def get_name_out(self, i: int) -> str:
        return self._fn.name_out(i)

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return self._fn.sparsity_in(i)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return self._fn.sparsity_out(i)


class Gated(Wrapped):
    """``fn`` (a CasADi function), refused past the thread's deadline."""

    def __init__(self, fn: ca.Function) -> None:
        super().__init__(fn)
        self._buf, self._eval = fn.buffer()
        self.construct(fn.name(), {})

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, args: tuple, res: tuple) -> int:
        if passed():
            return 1
        for i, a in enumerate(args):
            self._buf.set_arg(i, a)
        for i, r in enumerate(res):
            self._buf.set_res(i, r)
        self._eval()
        return int(self._buf.ret())
