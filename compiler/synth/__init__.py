"""Synthesis of a build folder with Yosys and nextpnr (``pendc report synth``, ``pendc explore``).

* :mod:`.flow` - :func:`~.flow.synthesize`: the tools' runs, the cache of their results, the
  report (:class:`~.flow.SynthReport`, :func:`~.flow.format_synth_report`);
* :mod:`.targets` - the FPGA targets as data (:data:`~.targets.TARGETS`), the pin harness, the
  capacity checks;
* :mod:`.netlist` - reading Yosys's netlist: cell counts and the logic depth.

A build folder is its whole input: it may import errors, atomic, codegen (the cache folder), the
backend's reading of a build's files and the passes' resource estimate (set beside the counts),
never model or ident. Imported by the command line and the sweep engine only.
"""
