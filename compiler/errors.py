"""The one exception type that user-facing code raises for bad input.

The CLI turns a :class:`PendcError` into a single ``pendc: error: ...`` line and a
non-zero exit; library users catch it like any other exception.
"""


class PendcError(Exception):
    """Bad input (model file, measurement file, argument) or a failed computation.

    The message is one line that names the problem and, where possible, the place
    (file, line, column, effect or parameter) where it was found.
    """
