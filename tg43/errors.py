"""Errors raised by the TG-43 engine for input the user can correct."""


class TG43Error(ValueError):
    """Bad input to the dose engine: the message names the input and the fix."""
