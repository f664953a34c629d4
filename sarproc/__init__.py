"""sarproc: SAR point-target simulation, focusing and quality evaluation.

Importing the package changes nothing in the process. The ``sarproc`` command sets the compiled kernels'
thread wait policy (``OMP_WAIT_POLICY=PASSIVE`` unless set, :func:`sarproc.cli.main.main`) and OpenBLAS's
(``OPENBLAS_THREAD_TIMEOUT=20`` unless set); a Python user who alternates the compiled kernels with
``scipy.fft`` sets them in the environment before the first kernel runs and numpy is imported
(docs/performance.md, "thread wait policy").
"""

__version__ = "0.1.0"
