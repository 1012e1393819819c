"""The table behind a registry of kinds (housings, measurements): a registry keeps one module per kind in
its ``kinds/`` subpackage, each module's class registers itself when it is imported, and the table imports
the modules the first time a kind is asked for."""

from __future__ import annotations

import importlib
import pkgutil
from typing import Generic, TypeVar

Kind = TypeVar("Kind")


def import_kind_modules(registry_package: str) -> None:
    """Import every module of ``registry_package``'s ``kinds`` subpackage, in name order."""
    package = importlib.import_module(f"{registry_package}.kinds")
    for module in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        importlib.import_module(f"{package.__name__}.{module.name}")


class KindTable(Generic[Kind]):
    """Name → class of the kinds of one registry (``what``: "housing", "measurement"); ``kinds`` is the
    table itself, filled by :meth:`add`."""

    def __init__(self, registry_package: str, what: str) -> None:
        self.kinds: dict[str, type[Kind]] = {}
        self._package, self._what, self._discovered = registry_package, what, False

    def add(self, name: str, cls: type[Kind]) -> None:
        """Register ``cls`` as ``name`` (a module imported twice registers the same class again)."""
        if name in self.kinds and self.kinds[name].__qualname__ != cls.__qualname__:
            raise TypeError(f"{self._what} kind {name!r} is defined twice")
        self.kinds[name] = cls

    def discover(self) -> None:
        """Import the kind modules once."""
        if not self._discovered:
            import_kind_modules(self._package)
            self._discovered = True

    def names(self) -> tuple[str, ...]:
        """Every registered kind, in the order the kinds ask for (their ``order``), then by name."""
        self.discover()
        return tuple(sorted(self.kinds, key=lambda n: (self.kinds[n].order, n)))

    def classes(self) -> tuple[type[Kind], ...]:
        return tuple(self.kinds[n] for n in self.names())
