"""A package's public names imported on first use (PEP 562), so that importing one part of a
package does not import all of it (``lgvtool.localize``, ``lgvtool.evaluate``)."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping


def lazy_names(package: str, exports: Mapping[str, str], namespace: dict[str, object]
               ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``: each name of ``exports``
    (name -> the submodule that defines it, or the full name of a module elsewhere in lgvtool)
    is imported from that module when first asked for and then kept in the package's
    ``namespace`` (its ``globals()``)."""

    def getattr_(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        full = module if module.startswith("lgvtool.") else f"{package}.{module}"
        value = getattr(importlib.import_module(full), name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return getattr_, dir_
