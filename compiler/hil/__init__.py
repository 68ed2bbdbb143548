"""Hardware-in-the-loop: a controller against a plant that steps, in lockstep.

* :mod:`.plants` - the stepping plants (float, golden, the Verilog under Verilator or Icarus);
* :mod:`.controllers` - the controllers and what they see (:class:`~.controllers.measurement.Measurement`);
* :mod:`.loop` - the lockstep loop: measure, ask the controller, hold its volts for a period;
* :mod:`.server` - the loop served to one external controller over TCP;
* :mod:`.records` - a run's files (run.csv, summary.json, run.png) and reading them back;
* :mod:`.scenarios` - the thesis' HIL tests and the model-mismatch test, with pass criteria;
  :mod:`.mismatch_report` - that test's figure for docs/hil.md;
* :mod:`.animate`, :mod:`.animate_html`, :mod:`.drawing` - a run drawn as its plant file's
  ``[drawing]`` (HTML, GIF, MP4).

The loop and the rest here import controllers and plants; controllers import only the plants'
port names; plants import neither. hil may import model, sim, golden, ir, backend, caching and
passes (a build's options, such as the core's step); only the command line and robust import it
(never model, sim, ir, passes, backend or ident).
"""
