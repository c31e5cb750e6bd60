"""Errors raised by scenespeak.

Every error a user can cause derives from :class:`ScenespeakError`, so that the command line
(and any caller) can catch it and print one line instead of a traceback. Errors are raised where
the input is first understood (calibration, image loading, database opening) and name the file
and the problem.
"""

from __future__ import annotations

from os import PathLike


class ScenespeakError(Exception):
    """Base class of every error scenespeak raises on purpose."""


class InputError(ScenespeakError, ValueError):
    """An input file or value could not be used.

    Parameters
    ----------
    source : str or path-like or None
        The file (or a short name of the value) that was wrong.
    problem : str
        What was wrong with it, and where possible what to do.

    Examples
    --------
    >>> str(InputError("left.png", "cannot be read as an image"))
    'left.png: cannot be read as an image'
    """

    def __init__(self, source: str | PathLike[str] | None, problem: str) -> None:
        self.source = None if source is None else str(source)
        self.problem = problem
        super().__init__(problem if self.source is None else f"{self.source}: {problem}")

    def __reduce__(self) -> tuple[type[InputError], tuple[str | None, str]]:
        # Picklable with its two fields, so that an error raised on a Dask worker (or in a
        # process pool) arrives on the client as the same error with the same message.
        return (type(self), (self.source, self.problem))


class CalibrationError(InputError):
    """A calibration file or value is invalid (missing keys, NaN, singular matrix, ...)."""


class ImageError(InputError):
    """An image is missing, unreadable, empty, or does not fit its pair."""


class DatabaseError(InputError):
    """An object database is missing, not ours, corrupt, or empty where objects are needed."""
