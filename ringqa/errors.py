"""Errors a user can act on.

Every error raised for bad input is a :class:`RingQAError` (or subclass) whose message names the
input (file, field or argument) and says how to fix it. The command line prints the message on
one line and exits non-zero; it never shows a traceback for these.
"""


class RingQAError(Exception):
    """Base class for errors caused by input the user can correct."""


class InputFileError(RingQAError):
    """A file could not be read correctly (format, missing field, bad value)."""

    def __init__(self, path, problem: str, fix: str = "") -> None:
        self.path = str(path)
        self.problem = problem
        self.fix = fix
        msg = f"{self.path}: {problem}"
        if fix:
            msg += f" ({fix})"
        super().__init__(msg)


class SceneError(RingQAError):
    """A scene file or setting is invalid (names the key)."""


class SimulationError(RingQAError):
    """A simulation could not be set up (as opposed to a run that jams, which is a result)."""


def named_warning(name: str, message: str) -> str:
    """A warning as one string, ``"[name] message"`` (name: the check, e.g. ``plan.isotope``).

    Warnings travel as plain strings (an RT Plan's ``warnings``, a result's ``warnings``) so that
    every stage can pass them on; :func:`split_warning` takes the name back out.
    """
    return f"[{name}] {message}"


def split_warning(text: str, default: str = "input") -> tuple[str, str]:
    """``(name, message)`` of a :func:`named_warning` string (``default`` for an unnamed one)."""
    text = str(text)
    if text.startswith("[") and "] " in text:
        name, message = text[1:].split("] ", 1)
        if name and " " not in name:
            return name, message
    return default, text
