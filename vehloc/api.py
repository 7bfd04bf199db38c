"""A package's API without its import cost: `__all__` names the public names of its modules, and each is imported
from its module when first used (PEP 562), so that importing one module of a package does not import them all."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence


def lazy_api(package: str, homes: Mapping[str, Sequence[str]]) -> tuple[list[str], Callable[[str], object]]:
    """`__all__` and the module `__getattr__` of `package`, whose public names live in its modules as `homes`
    says (module name -> names)."""
    home_of = {name: module for module, names in homes.items() for name in names}

    def __getattr__(name: str) -> object:
        if name not in home_of:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{home_of[name]}"), name)

    return sorted(home_of), __getattr__
