"""Discovery of kind modules: a registry (housings, measurements) keeps one module per kind in its
``kinds/`` subpackage, and each module registers its class when it is imported."""

from __future__ import annotations

import importlib
import pkgutil


def import_kind_modules(registry_package: str) -> None:
    """Import every module of ``registry_package``'s ``kinds`` subpackage, in name order."""
    package = importlib.import_module(f"{registry_package}.kinds")
    for module in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        importlib.import_module(f"{package.__name__}.{module.name}")
