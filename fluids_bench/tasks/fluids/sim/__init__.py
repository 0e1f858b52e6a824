"""The FLUIDS simulator: numpy arrays, shapely geometry and numba-compiled per-step loops (no
gymnasium import)."""
