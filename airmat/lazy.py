"""Lazy package exports (PEP 562): a package imports a submodule when one of its names is first used.

A package ``__init__`` names its public objects and the submodule that defines
each; ``import calib`` then costs nothing beyond ``airmat``, and importing one
submodule (``import airmat.design.mattress``) runs its own imports, not every sibling's.
``from calib import kappa1``, ``dir(calib)`` and ``from calib import *`` work
as with eager re-exports.

:func:`import_open3d` imports open3d with its ``visualization`` package
deferred: that package pulls in dash, plotly and IPython (0.4 s of the 0.8 s
open3d takes), and airmat uses only open3d's geometry and I/O.

Examples
--------
In ``calib/__init__.py``::

    __getattr__, __dir__, __all__ = attach(__name__, {"model": ["kappa1", "string_length"]})
"""

from __future__ import annotations

import importlib
import sys
import types

__all__ = ["attach", "import_open3d"]


class _ExportsShadowSubmodules(types.ModuleType):
    """A package where a public name equals the name of the submodule that defines it.

    ``airmat.calib.calibrate`` is the function of ``calib/calibrate.py``. Importing that
    submodule makes Python bind the module on the package under the same name
    (after the submodule ran), which would shadow the function; here the
    package keeps the function, as an eager ``from airmat.calib.calibrate import
    calibrate`` in the ``__init__`` did.
    """

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and value.__name__ == f"{self.__name__}.{name}" \
                and name in self.__dict__.get("_shadowed_by_export", ()):
            value = getattr(value, name)
        super().__setattr__(name, value)


def attach(package: str, exports: dict[str, list[str]]):
    """The ``__getattr__``, ``__dir__`` and ``__all__`` of a package with lazy exports.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : dict of str to list of str
        Submodule name relative to the package (``"model"`` for ``airmat.calib.model``)
        -> the public names it defines.

    Returns
    -------
    __getattr__ : callable
        Imports the defining submodule on first access to a public name and
        caches the value on the package.
    __dir__ : callable
        The package's attributes and every public name.
    __all__ : list of str
        The public names, in the order given.
    """
    table = {name: f"{package}.{module}" for module, names in exports.items() for name in names}
    if len(table) != sum(len(names) for names in exports.values()):
        raise ValueError(f"{package}: a public name is listed under two submodules")
    module = sys.modules[package]
    shadowed = {name for name, target in table.items() if target == f"{package}.{name}"}
    if shadowed:
        module._shadowed_by_export = frozenset(shadowed)
        module.__class__ = _ExportsShadowSubmodules

    def __getattr__(name):
        target = table.get(name)
        if target is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(target), name)
        setattr(module, name, value)
        return value

    def __dir__():
        return sorted(set(vars(module)) | set(table))

    return __getattr__, __dir__, list(table)


class _Deferred(types.ModuleType):
    """A stand-in for a package in ``sys.modules`` that imports the real one on first use.

    Only a name the stand-in lacks reaches ``__getattr__``, so the import system's own
    look-ups of its parent's import (``__spec__``) do not load it; the first other name,
    or ``__path__`` (a submodule of it imported), replaces the stand-in by the real
    package (in ``sys.modules`` and on the parent) and is answered from it.
    """

    def __getattr__(self, name):
        if name.startswith("__") and name != "__path__":      # __path__: a submodule imported through it
            raise AttributeError(name)
        if sys.modules.get(self.__name__) is self:
            del sys.modules[self.__name__]
        real = importlib.import_module(self.__name__)
        parent, _, child = self.__name__.rpartition(".")
        setattr(sys.modules[parent], child, real)
        return getattr(real, name)


def import_open3d():
    """The ``open3d`` module, imported without loading ``open3d.visualization`` until it is used.

    Same module and behaviour as ``import open3d``; ``open3d.visualization`` is a
    stand-in that loads the real package the first time one of its names is used.
    If open3d is already imported, it is returned as it is.

    Returns
    -------
    module
        ``open3d``.
    """
    if "open3d" in sys.modules:
        return sys.modules["open3d"]
    name = "open3d.visualization"
    stand_in = sys.modules.setdefault(name, _Deferred(name))
    try:
        import open3d
    except BaseException:
        if sys.modules.get(name) is stand_in:
            del sys.modules[name]
        raise
    if isinstance(stand_in, _Deferred) and sys.modules.get(name) is stand_in:
        open3d.visualization = stand_in
    return open3d
