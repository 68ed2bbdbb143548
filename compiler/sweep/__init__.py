"""Sweeps of independent tasks on Dask distributed, and the synthesis design-space sweep.

``engine`` runs any list of independent tasks (a picklable function and its arguments, keyed by
an index) on a LocalCluster or any Dask scheduler, keeps one result file per finished task,
resumes without repeating a task and keeps what finished on Ctrl-C: ``pendc robust``, ``pendc
explore`` and ``make fuzz`` all run on it. ``explore`` is ``pendc explore``'s work: a build and a
synthesis per (schedule, target), and the Pareto table of step time against multipliers and LUTs.
The package may import the rest of pendc; nothing outside it imports it but ``pendc.robust``'s
engine, the CLI (``cli/explore.py``) and bench/fuzz.py.
"""
