"""sarproc: SAR point-target simulation, focusing and quality evaluation."""

import os

# The compiled kernels (numba's OpenMP layer, GNU libgomp here) alternate with scipy.fft's own worker threads.
# libgomp's default wait policy keeps its workers spinning after every parallel region, on cores the next FFT
# needs: full exp. 2 fine-focus took 2.19-2.24 s with it and 1.62 s with passive waits (docs/performance.md),
# backprojection the same either way. Only a default, read when libgomp starts: a value set by the user wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"
