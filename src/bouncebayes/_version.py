"""The installed package version (one place, importable without the package namespace)."""

from importlib.metadata import version

__version__ = version("bouncebayes")
