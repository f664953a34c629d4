"""Signal-processing kernels shared by more than one algorithm: interpolation, phasors,
range compression.

May import sarproc.product only.
"""
