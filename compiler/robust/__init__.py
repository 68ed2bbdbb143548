"""Monte-Carlo HIL on Dask (``pendc robust``): does a controller designed on the nominal model hold
across every plant the data allow, and which parameter breaks it?

``sampling`` draws plant parameters (Latin hypercube or Sobol over ``--vary`` ranges, a fit's
covariance, or the documented default ranges), ``scenario_runner`` runs one closed-loop scenario
against one sampled plant and returns one row, ``golden_retype`` gives a sampled model's golden
plant from the nominal build without a new compile, ``engine`` distributes the rows over a Dask
cluster, ``results`` writes the rows (Parquet and CSV), the summary and the worst runs,
``sensitivity`` ranks the parameters (SALib), ``report`` draws the HTML page. The package may
import the rest of pendc; nothing outside it imports it but the CLI (``cli/robust.py``).
"""
