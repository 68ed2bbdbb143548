"""``python -m pendc.cli``: the same as the ``pendc`` script."""

import sys

from .program import main

sys.exit(main())
