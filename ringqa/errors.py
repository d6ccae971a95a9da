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
