"""The one exception hierarchy of trimd; the CLI turns each into a message and exit code."""

__all__ = ["DataError", "EstimationError", "LinkError", "NoResultError", "ProfileError",
           "TrimdError", "UsageError"]


class TrimdError(Exception):
    """Base of every error trimd raises on purpose (user error or unusable data)."""


class ProfileError(TrimdError, ValueError):
    """A vehicle profile is missing a key, has a wrong type, unit or value."""


class DataError(TrimdError, ValueError):
    """An input file (hold CSV, estimate JSON, log) cannot be used as it is."""


class EstimationError(TrimdError, RuntimeError):
    """The data cannot determine the requested quantities (unidentifiable, too few holds)."""


class LinkError(TrimdError, ConnectionError):
    """A vehicle link cannot be opened or was lost."""


class UsageError(TrimdError):
    """The command line asks for something trimd cannot do (a missing or bad argument);
    ``prog`` names the command, ``usage`` is its usage text ("" for none)."""

    def __init__(self, message: str, prog: str = "trimd", usage: str = "") -> None:
        super().__init__(message)
        self.prog = prog
        self.usage = usage


class NoResultError(TrimdError):
    """Usable input that yields no result (a log with nothing to estimate from)."""
