"""ringqa: commissioning QA for HDR brachytherapy ring applicators.

Architecture (data flows one way, left to right; no module imports from a module to its right)::

    units, errors, paths  ->  geometry  ->  io (importers)  ->  simulation  ->  plan/dose  ->
    pipeline  ->  report  ->  cli

``tg43`` (the dose engine) is a separate top-level package that never imports ``ringqa``.
Importing ``ringqa`` has no side effects (no JIT compilation, no file access).
"""

__all__ = ["__version__"]


def __getattr__(name: str) -> str:
    """``__version__``, looked up in the installed package's metadata on first use
    (``importlib.metadata`` is not imported by every ``import ringqa.x``: ``ringqa --help``)."""
    if name != "__version__":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("ringqa")
    except PackageNotFoundError:  # running from a checkout without installation
        value = "0.0.0+checkout"
    globals()["__version__"] = value
    return value
