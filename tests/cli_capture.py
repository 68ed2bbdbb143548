"""Running the command line inside a test: its exit status and what it printed, with any
Python warning turned into a failure (no warning may reach a user's terminal)."""

import warnings

from pendc.cli import main


def run_cli(capsys, *argv):
    """``(exit status, stdout, stderr)`` of ``pendc ARGV``; a Python warning raises."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err
