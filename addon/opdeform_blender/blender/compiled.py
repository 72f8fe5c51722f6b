"""The compiled opdeform module as the add-on found it (core/loader.py), and AddonError, the add-on's
user-facing error. The lowest module of blender/: everything above may raise AddonError or reach opdeform."""

import importlib

from ..core import loader

ADDON_PACKAGE = __package__.rpartition(".")[0]  # the add-on's package (its __init__ defines the same name)


class AddonError(Exception):
    """A user-facing problem: shown as an error report (operators) or in the panel (handlers)."""


def module():
    od, error = loader.load(ADDON_PACKAGE)
    if od is None:
        raise AddonError(error)
    return od


def mpm():
    """The loaded opdeform's mpm module; AddonError when none loaded."""
    return importlib.import_module(module().__name__ + ".mpm")
