"""Model files with shortened training, for tests of what a build does rather than of its formats."""

from pathlib import Path

# appended to a model file: 2 % of the training stimuli, the error budget checked over 50 ms
QUICK = "\n[hardware]\ntraining_scale = 0.02\ncheck_seconds = 0.05\n"


def quick_copy(model_file: Path, dest: Path) -> Path:
    """``model_file`` with ``QUICK`` appended, written to ``dest``; returns ``dest``."""
    dest.write_text(Path(model_file).read_text() + QUICK)
    return dest
