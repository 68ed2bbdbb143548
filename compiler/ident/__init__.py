"""Identification workbench: compare a model with measurements, find the missing effect, refit.

* :mod:`.compare` - free-run simulation against one measured run: fit%, worst time
  windows, error per operating regime, residual whiteness (``pendc compare``);
* :mod:`.report_html` - the same as one self-contained HTML page with plots;
* :mod:`.shooting`, :mod:`.fit` - multiple-shooting residual and bounded parameter fit;
* :mod:`.diagnose`, :mod:`.evidence` - which catalogue effect is missing, and why;
* :mod:`.datagen` - measurement-like data from models with hidden effects.

This package may import :mod:`pendc.model` and :mod:`pendc.sim`, never the compiler
(ir, passes, backend).
"""
