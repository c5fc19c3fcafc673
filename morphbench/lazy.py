"""Imports on first use: package names, so that importing one light module of a package (the results schema, the
metrics) does not import the simulator with the package's other modules; and libraries whose import would swallow a
Ctrl-C."""

from __future__ import annotations

import importlib
import signal
import sys
import threading
import types
from collections.abc import Mapping


def export_lazily(package: str, exports: Mapping[str, str]) -> None:
    """Make each name of ``exports`` (name -> submodule of ``package`` that defines it) an attribute of the package,
    imported from its submodule the first time it is asked for; ``__all__`` lists them."""

    class LazyPackage(types.ModuleType):
        def __getattr__(self, name: str):
            if name not in exports:
                raise AttributeError(f"module {package!r} has no attribute {name!r}")
            value = getattr(importlib.import_module(f"{package}.{exports[name]}"), name)
            setattr(self, name, value)
            return value

        def __setattr__(self, name: str, value) -> None:
            # Importing a submodule binds it on its package: the submodule run must not hide the function run.
            if name in exports and isinstance(value, types.ModuleType):
                return
            super().__setattr__(name, value)

    module = sys.modules[package]
    module.__class__ = LazyPackage
    module.__all__ = sorted(exports)


def import_keeping_interrupts(name: str) -> types.ModuleType:
    """``importlib.import_module(name)`` for a library whose import catches ``BaseException`` (trimesh wraps each of
    its optional imports so): a Ctrl-C that lands during it would be swallowed and the command would go on. In the
    main thread the signal is held while the module imports and delivered again, to whatever handler was there, after
    it."""
    if name in sys.modules or threading.current_thread() is not threading.main_thread():
        return importlib.import_module(name)
    held = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        return importlib.import_module(name)
    finally:
        signal.signal(signal.SIGINT, previous)
        if held:
            signal.raise_signal(signal.SIGINT)
