"""Typed errors shared by every subpackage.

A :class:`LgvError` is a user-facing failure: the command line prints its message as one line on
stderr and exits with :attr:`LgvError.exit_code`, never with a traceback.
"""

from __future__ import annotations


class LgvError(Exception):
    """Base of every error that the command line reports as one line.

    ``exit_code`` follows the CLI convention: 2 bad input or usage, 1 a checked threshold failed.
    """

    exit_code: int = 2


class InputError(LgvError):
    """A file, option or value given by the user is not usable."""


class ConfigError(InputError):
    """A configuration file or ``--set`` override is invalid."""


class LogFormatError(InputError):
    """A file is not an MCAP log that lgvtool can read."""


class MissingDataError(InputError):
    """A log lacks the channels a command needs (e.g. no motion data)."""


class ThresholdError(LgvError):
    """A regression check (``--max``, ``--baseline``) failed."""

    exit_code = 1


def decoding_error(path: object, topic: str, schema: str, exc: BaseException) -> LogFormatError:
    """The one-line error of messages of ``topic`` in the log at ``path`` that do not match
    ``schema`` (``exc``: the failure met in decoding them)."""
    return LogFormatError(f"{path}: topic {topic}: messages do not match schema {schema} "
                          f"({type(exc).__name__}: {exc})")
