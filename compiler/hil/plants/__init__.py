"""Plants that step: one interface (:class:`~.plant_state.Plant`) for the float simulator, the
golden model and the generated Verilog.

* :mod:`.plant` - :func:`~.plant.make_plant` (``--plant float|golden|verilator|icarus``), the
  float plant, the start state and its encoder counts;
* :mod:`.plant_state` - what every plant shares: the state it returns, the step request's and
  the start state's checks, the ×4 encoder counting;
* :mod:`.golden_plant` - the golden model continued step after step;
* :mod:`.rtl_plant`, :mod:`.rtl_harness` - the Verilog under Verilator or Icarus in lockstep
  over pipes, and that harness (also the testbench's, ``tb/vbinary.py``);
* :mod:`.rtl_cpp` - the Verilog under a plain C++ Verilator harness (the fast one);
* :mod:`.rtl_build` - building a simulator executable once per design hash;
* :mod:`.core_ports` - the generated core's ports as the plant interface names them.

May import model, sim, golden, ir, backend, caching, codegen and errors; never the controllers or
the loop (they import the plants). ``make_plant`` is re-exported: ``from pendc.hil.plants import
make_plant``, on first use: a cocotb simulator unpickles its vectors' :class:`~.core_ports.CorePorts`
and needs this package, not the plants (which import sympy and the model modules).
"""

__all__ = ["make_plant"]


def __getattr__(name: str):
    if name != "make_plant":
        raise AttributeError(f"module 'pendc.hil.plants' has no attribute {name!r}")
    from .plant import make_plant
    return make_plant
