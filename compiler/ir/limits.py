"""The IR's hard limits, each defined once and named by what it bounds.

The verifier enforces them; passes that choose widths or sizes stay inside them.
Tuning knobs of a pass (how far the error budget may grow a table, ...) are not
limits of the IR and live with their pass, under names that say so.
"""

MULT_OPERAND_BITS = 32      # widest multiplier operand (GAIN input and constant, MUL inputs): one DSP-friendly operand
EXACT_BITS = 64             # every exact intermediate fits a machine integer of the compiled golden model
MAX_LUT_ADDR_BITS = 20      # largest table: a typo (addr_bits=100) must not make tabulation try 2**100 entries
