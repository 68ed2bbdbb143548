"""Constants shared by the testbench host side and the cocotb modules."""

from __future__ import annotations

from pathlib import Path

TB_DIR = Path(__file__).resolve().parent
REPO = TB_DIR.parent
SIMS = ("icarus", "verilator")
PERIOD_NS = 10                      # clock period of every simulation
CHUNK = 1000                        # model steps per sample of the 1 kHz stimuli at the default 1 us step
WINDOW = 2000                       # steps of every bit-exact, every-step window
WINDOW_POINTS = (0.3, 0.6, 0.9)     # besides the start: where in each stimulus windows begin
LONG_CHUNKS = {"chirp": 2000, "random": 1000}   # 2 s of the chirp, 1 s of full-scale random levels
QUICK_LONG_CHUNKS = 10              # the quick profile's excerpt of a long run (Icarus: ~1.5 k steps/s)
BUS_LEVELS = {"u_pos": 1.3, "u_neg": -2.0}      # stimulus levels (pendc.sim.stimuli) for the bus tests
BUS_STEPS = 4000
TB_TOP = "tb_plant_core"            # the core plus the testbench's own x4 decoders (pendtb.tb_top_source)
VERSION = 4                          # of the vector file layout
MIN_VERILATOR = (5, 36)
WINDOW_STIMULI = ("chirp_low", "chirp_high", "steps", "swing_up", "random",   # the training set
                  "multisine_seed7_1MHz", "steps_other_levels")                 # never seen in training

# What each cocotb test reads of the golden vectors (tb/test_core.py, tb/test_bus.py): the
# windows of these stimuli, these long runs, the overflow scenario, the bus runs. A run of some
# tests only (tb/run.py -k) computes no more (pendtb.vector_options); a test that reads more than
# it says here fails on the missing part, it cannot pass on it.
TEST_VECTORS = {
    "test_core.reset_state": {"windows": ("chirp_low",)},
    **{f"test_core.every_step/stim={s}": {"windows": (s,)} for s in WINDOW_STIMULI},
    "test_core.long_run_chirp": {"long": ("chirp",)},
    "test_core.encoders_decode": {"long": ("random",)},
    "test_core.converters_code": {"long": ("chirp",)},
    "test_core.overflow_full_push": {"windows": ("chirp_low",), "overflow": True},
    "test_core.reset_mid_run": {"windows": ("random",)},
    "test_core.step_handshake": {"windows": ("multisine_seed7_1MHz",)},
    **{f"test_bus.{t}": {"bus": True} for t in ("reset_values", "read_write", "unmapped", "lockstep", "free_run",
                                                 "soft_and_hard_reset", "step_counter")},
    "test_bus.overflow_flags": {"bus": True, "overflow": True},
}



def verilog_files(hdl_dir: Path) -> list[Path]:
    """The Verilog files of an HDL folder, sorted."""
    return sorted(Path(hdl_dir).glob("*.v"))


def sampling(dt: float) -> tuple[int, float]:
    """``(chunk, fs)``: model steps per sample of the testbench's stimuli and their rate, for a
    core stepping ``dt`` s. About 1 kHz (a sample every millisecond, as a HIL controller's period):
    at the default 1 us step, CHUNK steps at exactly 1000 Hz; a core slower than 1 ms a step
    (a [hardware] dt of 2 ms, 10 ms) gets a sample every step."""
    chunk = max(1, int(round(1e-3 / dt)))
    return chunk, 1.0 / (chunk * dt)        # exactly 1000.0 at 1 us (and 0.25, 0.5, 10, 100 us, 1 ms)
