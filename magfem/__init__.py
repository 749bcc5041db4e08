"""magfem: finite-element simulation of untethered hard-magnetic soft robots.

Stages, one module or package each, in the order the data flows
(docs/physics.md): ``case`` (validated TOML input) -> ``geometry`` (gmsh
robots and field sources) -> ``field`` (magnetostatics, waveforms, field
models) -> ``material`` + ``mechanics`` (finite-strain dynamics) ->
observers/output; ``sweep``, ``study`` and ``report`` run studies of cases.
"""

from __future__ import annotations

import os
import sys

try:  # the PyPI wheel orders MPI ahead of the compiled bindings
    import dolfinx_solver  # noqa: F401
except ImportError:  # another dolfinx 0.11 install (conda-forge, source)
    pass

# Off-screen pictures on a machine without a display: VTK would try X first and print
# "bad X server connection" before falling back to EGL; ask for EGL directly.
if sys.platform.startswith("linux") and not (
    os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

__version__ = "0.1.0"
