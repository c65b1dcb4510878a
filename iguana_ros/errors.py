"""Exceptions that the CLI turns into one clear line and a non-zero exit status."""


class IguanaError(Exception):
    """A user-facing error: bad input, a missing or corrupt file, a failed run."""


class InputError(IguanaError, ValueError):
    """An argument, message or file has a wrong value, shape or format."""
