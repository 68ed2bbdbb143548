"""Constants shared by the testbench host side and the cocotb modules."""

from __future__ import annotations

from pathlib import Path

TB_DIR = Path(__file__).resolve().parent
REPO = TB_DIR.parent
SIMS = ("icarus", "verilator")
PERIOD_NS = 10                      # clock period of every simulation
CHUNK = 1000                        # model steps per sample of the 1 kHz stimuli
WINDOW = 2000                       # steps of every bit-exact, every-step window
WINDOW_POINTS = (0.3, 0.6, 0.9)     # besides the start: where in each stimulus windows begin
LONG_CHUNKS = {"chirp": 2000, "random": 1000}   # 2 s of the chirp, 1 s of full-scale random levels
BUS_LEVELS = {"u_pos": 1.3, "u_neg": -2.0}      # stimulus levels (pendc.sim.stimuli) for the bus tests
BUS_STEPS = 4000
TB_TOP = "tb_plant_core"            # the core plus the testbench's own x4 decoders (pendtb.tb_top_source)
VERSION = 4                          # of the vector file layout
MIN_VERILATOR = (5, 36)
WINDOW_STIMULI = ("chirp_low", "chirp_high", "steps", "swing_up", "random",   # the training set
                  "multisine_seed7_1MHz", "steps_other_levels")                 # never seen in training



def verilog_files(hdl_dir: Path) -> list[Path]:
    """The Verilog files of an HDL folder, sorted."""
    return sorted(Path(hdl_dir).glob("*.v"))
