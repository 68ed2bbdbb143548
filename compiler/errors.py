"""The one exception type that user-facing code raises for bad input.

The CLI turns a :class:`PendcError` into a single ``pendc: error: ...`` line and a
non-zero exit; library users catch it like any other exception.
"""


class PendcError(Exception):
    """Bad input (model file, measurement file, argument) or a failed computation.

    The message is one line that names the problem and, where possible, the place
    (file, line, column, effect or parameter) where it was found.
    """


def open_input(path, what: str):
    """``path`` opened for binary reading, or a :class:`PendcError` naming it and ``what`` it
    should be ("model file", "measurement file"): missing, a folder, or unreadable."""
    try:
        return open(path, "rb")
    except FileNotFoundError:
        raise PendcError(f"{path}: {what} not found") from None
    except IsADirectoryError:
        raise PendcError(f"{path}: is a folder, not a {what}") from None
    except OSError as exc:
        raise PendcError(f"{path}: cannot read {what} ({exc.strerror or exc})") from None
