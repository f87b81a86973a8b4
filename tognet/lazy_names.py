"""Package names loaded on first use (PEP 562), so `tognet --help` need not import torch or trimesh.

The one lazy-import mechanism of tognet: a package lists ``name -> "module"`` (or ``"module:attribute"``
when the name differs from the module's) and sets ``__getattr__, __dir__ = lazy_names(__name__, WHERE)``.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from typing import Any


def lazy_names(package: str, where: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A module's ``__getattr__`` and ``__dir__`` for ``package``: each name in ``where`` comes from the
    module named there (``"module:attribute"``: that attribute of it), imported (and the name cached in
    the package) on first use."""

    def __getattr__(name: str) -> Any:
        spec = where.get(name)
        if spec is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attribute = spec.partition(":")
        value = getattr(importlib.import_module(module), attribute or name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *where})

    return __getattr__, __dir__
