"""Point-target quality metrics (IRW, PSLR, ISLR, position, false targets) and their plots.

May import sarproc.product only.
"""
