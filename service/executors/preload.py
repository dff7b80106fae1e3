"""Imported by the job fork server: compile-or-load numba kernels once.

Jobs run in processes forked from the fork server, so whatever the server
has loaded, every job has for free. numba compiles (or loads from its disk
cache) a kernel on its first call; calling each kernel once here on a tiny
input moves that cost (about 0.4 s) from every job to the service start.
"""

import numpy as np

from meshcore.delaunay import delaunay

delaunay(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
