"""Names imported on first use (PEP 562): a package's public names, or a stage's front
door, as a table of home modules, so that importing it loads nothing until a name is used.

A module declares ``LAZY_IMPORTS = {"home.module": ("Name", ...), ...}`` (a literal: the
import rules of ``tests/test_layers.py`` read it as that module's imports) and
``__getattr__, __dir__ = lazy_names(__name__, LAZY_IMPORTS)``.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable


def lazy_names(module: str, table: dict[str, tuple[str, ...]]
               ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of module ``module`` serving ``table``.

    Parameters
    ----------
    module : str
        The serving module's ``__name__``.
    table : dict of str to tuple of str
        Home module -> the names it defines that ``module`` serves (each name once).

    Raises
    ------
    ValueError
        A name listed under two home modules.
    """
    homes = {name: home for home, names in table.items() for name in names}
    if len(homes) != sum(len(names) for names in table.values()):
        raise ValueError(f"{module}: a name is listed under two home modules")

    def __getattr__(name: str) -> object:
        if name not in homes:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(homes[name]), name)
        setattr(sys.modules[module], name, value)  # the next lookup finds it directly
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[module]), *homes})

    return __getattr__, __dir__
