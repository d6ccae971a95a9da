"""ringqa: commissioning QA for HDR brachytherapy ring applicators.

Architecture (data flows one way, left to right; no module imports from a module to its right)::

    units, errors, paths  ->  geometry  ->  io (importers)  ->  simulation  ->  plan/dose  ->
    pipeline  ->  report  ->  cli

``tg43`` (the dose engine) is a separate top-level package that never imports ``ringqa``.
Importing ``ringqa`` has no side effects (no JIT compilation, no file access).
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ringqa")
except PackageNotFoundError:  # running from a checkout without installation
    __version__ = "0.0.0+checkout"

__all__ = ["__version__"]
