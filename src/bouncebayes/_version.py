"""The installed package version (one place, importable without the package namespace).

Run from a source tree that was never installed (``PYTHONPATH=src``), there is no package
metadata: the version is then the source tree's, marked as such, so that provenance records
say where the numbers came from rather than the run failing.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("bouncebayes")
except PackageNotFoundError:  # a source tree on the path, not installed
    __version__ = "0+unknown.source-tree"
