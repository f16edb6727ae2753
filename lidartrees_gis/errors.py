"""Exception hierarchy of lidartrees_gis.

Every error raised on purpose by the library derives from :class:`LidarTreesError`.
Subclasses also derive from the matching built-in so callers can catch either.
Messages say what is wrong, where (file:line or parameter), the bad value and what to do.
"""


class LidarTreesError(Exception):
    """Root of all lidartrees_gis errors."""


class InputError(LidarTreesError, ValueError):
    """Bad input data or a bad parameter value."""


class ReadError(LidarTreesError, OSError):
    """A file cannot be opened or read."""


class CRSError(LidarTreesError, ValueError):
    """A coordinate reference system is missing, unknown or cannot be transformed."""


class OutputError(LidarTreesError, OSError):
    """An output cannot be written (read-only folder, no permission)."""


class OutputExistsError(LidarTreesError, FileExistsError):
    """An output exists and overwriting was not allowed."""


class Cancelled(LidarTreesError):
    """The user cancelled the operation."""


class DataWarning(UserWarning):
    """Something in the input was odd but the run went on (points outside the header bounds,
    a point count that does not match the file); the CLI prints it as one line."""


def listing(names, first: int = 5) -> str:
    """``a, b, c`` of the first ``first`` names, `` ...`` after them when there are more (an
    error or warning names what is wrong without hiding that it named only some)."""
    names = [str(n) for n in names]
    return ", ".join(names[:first]) + (" ..." if len(names) > first else "")
