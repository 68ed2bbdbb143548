"""The tool's own caching: what pendc keeps between runs so that a second run is fast.

* :mod:`.build_cache` - compiled models (range analysis, error budget) by model, options and
  the compiler's source, with a lock so that two processes compile an entry once;
* :mod:`.objcache` - Verilator's runtime objects across builds (make's OBJCACHE hook; runs as a
  script that imports only the standard library).

The cache folder itself is :func:`pendc.codegen.cache_dir`. May import model, passes and
codegen; imported by the command line, hil's plants and the synthesis, never by model, ir or
passes.
"""
