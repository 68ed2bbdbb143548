"""Compiler passes, called in order by pendc.passes.pipeline."""
