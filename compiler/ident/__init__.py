"""Identification workbench: compare a model with measurements, find the missing effect, refit.

One line per module:

* :mod:`.compare` - free-run and horizon simulation against one measured run: fit%, worst
  windows, error per operating regime, residual whiteness (``pendc compare``);
* :mod:`.regimes` - the operating regimes (motion, swing, drive, travel, saturation) read off
  the plant interface;
* :mod:`.sidebyside` - several models on the same runs, one shared headline per run;
* :mod:`.headline` - which fit figure leads (free-run or horizon), decided from the data;
* :mod:`.horizon` - the k-step simulation restarting from the measured state, for figures and plots;
* :mod:`.figures` - labelled fit figures (free-run / horizon, pooled and per file);
* :mod:`.whiteness` - residual autocorrelation and input cross-correlation tests, as MATLAB's resid;
* :mod:`.report_text` - the plain-text report of compare;
* :mod:`.report_html` - the same as one self-contained HTML page;
* :mod:`.report_plots` - the matplotlib figures of that page;
* :mod:`.outputs` - which outputs are compared and how each is weighted (spread vs resolution);
* :mod:`.shooting` - the multiple-shooting residual, each file under its own experiment;
* :mod:`.smoothing` - the derivative filters (velocities, accelerations from encoder positions);
* :mod:`.start_rates` - start rates from a segment's own samples where a coarse sensor's filter fails;
* :mod:`.units` - how reports print a signal by its interface unit (mm, mrad, rad);
* :mod:`.fit` - bounded parameter fit with intervals and refusal of what the data do not identify;
* :mod:`.diagnose` - which catalogue effect is missing: fit on half the data, score on the other;
* :mod:`.ties` - when the data cannot separate the best candidates, and which experiment would;
* :mod:`.evidence` - the equation error (acceleration per coordinate) behind a diagnosis, in words;
* :mod:`.noise` - the residual the measurement chain alone leaves ("nothing systematic left");
* :mod:`.datagen` - measurement-like data from models with hidden effects.

This package may import :mod:`pendc.model` and :mod:`pendc.sim`, never the compiler
(ir, passes, backend). It names no state of any plant: the positions compared, their rates,
units, encoder counts and periods come from the model's plant interface
(:mod:`pendc.sim.signals`).
"""
