"""Focusing algorithms: the exact backprojection reference and one sub-package per family.

May import sarproc.dsp, sarproc.quality and sarproc.product; never the simulator or the CLI.
"""
