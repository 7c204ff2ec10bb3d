"""Headless outputs over the engine: file loading that needs VTK, results, the command line."""
