"""Verilog backend: view-model, templates, files."""
