"""The FLUIDS simulator: numpy and shapely only (no gymnasium import)."""
