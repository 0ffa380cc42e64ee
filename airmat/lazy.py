"""Lazy package exports (PEP 562): a package imports a submodule when one of its names is first used.

A package ``__init__`` names its public objects and the submodule that defines
each; ``import calib`` then costs nothing beyond ``airmat``, and importing one
submodule (``import design.mattress``) no longer runs every sibling's imports.
``from calib import kappa1``, ``dir(calib)`` and ``from calib import *`` work
as with eager re-exports.

Examples
--------
In ``calib/__init__.py``::

    __getattr__, __dir__, __all__ = attach(__name__, {"model": ["kappa1", "string_length"]})
"""

from __future__ import annotations

import importlib
import sys
import types

__all__ = ["attach"]


class _ExportsShadowSubmodules(types.ModuleType):
    """A package where a public name equals the name of the submodule that defines it.

    ``calib.calibrate`` is the function of ``calib/calibrate.py``. Importing that
    submodule makes Python bind the module on the package under the same name
    (after the submodule ran), which would shadow the function; here the
    package keeps the function, as an eager ``from calib.calibrate import
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
        Submodule name relative to the package (``"model"`` for ``calib.model``)
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
