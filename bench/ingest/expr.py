"""Arithmetic over a file's columns, for mapping entries like ``expr = "{U [V]} * {I [A]}"``.

A small recursive-descent parser (never ``eval``) for the grammar::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | atom
    atom   := NUMBER | "{" column name "}" | "(" expr ")"

Column names are written in braces exactly as in the file's header (a name may
hold spaces, brackets and any character but ``}``); numbers are decimal, with an
optional exponent (``1e3``). The parsed tree is evaluated element-wise over
numpy arrays.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


class ExprError(ValueError):
    """A syntax error in an expression.

    Parameters
    ----------
    problem : str
        What is wrong.
    position : int
        0-based character offset in the expression text where it was found.
    """

    def __init__(self, problem: str, position: int) -> None:
        super().__init__(problem)
        self.problem = problem
        self.position = position


@dataclass(frozen=True)
class Number:
    """A numeric literal."""

    value: float


@dataclass(frozen=True)
class Column:
    """A column reference ``{name}``; ``position`` is the offset of its ``{``."""

    name: str
    position: int


@dataclass(frozen=True)
class Negate:
    """Unary minus."""

    operand: Node


@dataclass(frozen=True)
class Binary:
    """``left op right`` with ``op`` one of ``+ - * /``."""

    op: str
    left: Node
    right: Node


Node = Number | Column | Negate | Binary

_NUMBER = re.compile(r"(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


@dataclass
class _Token:
    kind: str  # "num", "col", "op", "end"
    text: str
    position: int


def _tokens(text: str) -> list[_Token]:
    out: list[_Token] = []
    i = 0
    while i < len(text):
        c = text[i]
        if c.isspace():
            i += 1
        elif c == "{":
            end = text.find("}", i + 1)
            if end < 0:
                raise ExprError("'{' without a closing '}'", i)
            name = text[i + 1 : end].strip()
            if not name:
                raise ExprError("empty column name '{}'", i)
            out.append(_Token("col", name, i))
            i = end + 1
        elif c in "+-*/()":
            out.append(_Token("op", c, i))
            i += 1
        else:
            m = _NUMBER.match(text, i)
            if m is None:
                raise ExprError(f"unexpected character {c!r} (column names go in braces)", i)
            out.append(_Token("num", m.group(0), i))
            i = m.end()
    out.append(_Token("end", "", len(text)))
    return out


#: limits that keep parsing and evaluation far from Python's recursion limit; a
#: mapping's formula needs a handful of terms and parentheses
MAX_NESTING = 32
MAX_TOKENS = 400


class _Parser:
    def __init__(self, text: str) -> None:
        self.toks = _tokens(text)
        self.k = 0
        self.depth = 0
        if len(self.toks) > MAX_TOKENS:
            tok = self.toks[MAX_TOKENS]
            raise ExprError(f"more than {MAX_TOKENS} numbers, columns and operators",
                            tok.position)

    def peek(self) -> _Token:
        return self.toks[self.k]

    def take(self) -> _Token:
        tok = self.toks[self.k]
        self.k += 1
        return tok

    def expr(self) -> Node:
        node = self.term()
        while self.peek().kind == "op" and self.peek().text in "+-":
            op = self.take().text
            node = Binary(op, node, self.term())
        return node

    def term(self) -> Node:
        node = self.unary()
        while self.peek().kind == "op" and self.peek().text in "*/":
            op = self.take().text
            node = Binary(op, node, self.unary())
        return node

    def unary(self) -> Node:
        signs = []  # iterative: a run of 1000 signs is no recursion
        while self.peek().kind == "op" and self.peek().text in "+-":
            signs.append(self.take().text)
        node = self.atom()
        return Negate(node) if signs.count("-") % 2 else node

    def atom(self) -> Node:
        tok = self.take()
        if tok.kind == "num":
            return Number(float(tok.text))
        if tok.kind == "col":
            return Column(tok.text, tok.position)
        if tok.kind == "op" and tok.text == "(":
            self.depth += 1
            if self.depth > MAX_NESTING:
                raise ExprError(f"more than {MAX_NESTING} nested parentheses", tok.position)
            node = self.expr()
            self.depth -= 1
            close = self.take()
            if not (close.kind == "op" and close.text == ")"):
                raise ExprError(f"expected ')' {_found(close)}", close.position)
            return node
        raise ExprError(f"expected a number, a {{column}} or '(' {_found(tok)}", tok.position)


def _found(tok: _Token) -> str:
    return "at the end" if tok.kind == "end" else f"but found {tok.text!r}"


def parse(text: str) -> Node:
    """Parse an expression into a tree.

    Raises
    ------
    ExprError
        A syntax error, with the 0-based offset where it was found.
    """
    if not text.strip():
        raise ExprError("empty expression", 0)
    p = _Parser(text)
    node = p.expr()
    end = p.peek()
    if end.kind != "end":
        raise ExprError(f"unexpected {end.text!r} after a complete expression", end.position)
    return node


def columns(node: Node) -> list[Column]:
    """The column references of a tree, left to right (repeats kept)."""
    if isinstance(node, Column):
        return [node]
    if isinstance(node, Negate):
        return columns(node.operand)
    if isinstance(node, Binary):
        return columns(node.left) + columns(node.right)
    return []


def evaluate(node: Node, value_of: Callable[[str], np.ndarray]) -> np.ndarray | float:
    """Evaluate a tree element-wise; ``value_of(name)`` gives a column's float64 array.

    Division by zero gives inf or NaN (numpy semantics, no warning); callers
    treat non-finite results as invalid samples.
    """
    if isinstance(node, Number):
        return node.value
    if isinstance(node, Column):
        return value_of(node.name)
    if isinstance(node, Negate):
        return -evaluate(node.operand, value_of)
    a, b = evaluate(node.left, value_of), evaluate(node.right, value_of)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if node.op == "+":
            return a + b
        if node.op == "-":
            return a - b
        if node.op == "*":
            return a * b
        return a / b


def sum_of(names: list[str]) -> Node:
    """The tree of ``{names[0]} + {names[1]} + ...`` (a mapping's ``sum``)."""
    node: Node = Column(names[0], 0)
    for name in names[1:]:
        node = Binary("+", node, Column(name, 0))
    return node


def pointer(text: str, position: int) -> str:
    """``text`` and a caret line under ``position`` (for error messages)."""
    return f"{text}\n{' ' * position}^"
