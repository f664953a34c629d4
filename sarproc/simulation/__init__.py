"""The point-target simulator: scene model, exact-geometry echoes and the effect plugins.

May import sarproc.dsp, sarproc.quality and sarproc.product; never the focusers or the CLI.
"""
