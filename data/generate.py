"""Regenerate the shipped measurement-like data files of data/ (deterministic).

Usage: .venv/bin/python data/generate.py [folder]
Each file is the thesis' final model with hidden effects, simulated at 1 us on the
standard identification experiment, with a 12-bit DAC, unmeasured input noise and
x4 encoder quantisation (see pendc.ident.datagen).
"""

import sys
from pathlib import Path

from pendc import load_model
from pendc.ident.datagen import demo_datasets
from pendc.sim.measurements import write_csv


def main() -> int:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    for name, (columns, description, *extra) in demo_datasets(load_model()).items():
        meta = {"description": description, "generator": "data/generate.py", **(extra[0] if extra else {})}
        write_csv(folder / f"{name}.csv", columns, meta=meta)
        print(f"wrote {folder / name}.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
