"""The SCT plant's Table 3 parameters recomputed from the thesis' raw measurements, beside the
printed figures: ``python data/sct_thesis/derive.py [--json]``.

This is the provenance of the numbers in models/sct_thesis_final.toml. It lives beside the
plant's data, not in pendc: the compiler knows no plant; a derivation like this one is part of
a plant's own record (``thesis_data.py`` holds the raw figures, ``provenance.py`` the
derivations, equation and table numbers quoted from ``shared/reference/thesis.txt``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from provenance import derive_parameters, derived_to_json, format_derived_table  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="derive.py", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="JSON instead of the aligned table")
    args = ap.parse_args(argv)
    derived = derive_parameters()
    if args.json:
        json.dump(derived_to_json(derived), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_derived_table(derived))
    return 0


if __name__ == "__main__":
    sys.exit(main())
