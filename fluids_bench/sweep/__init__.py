"""Sensitivity sweeps (ch. 7, Fig. 7.6): a parameter grid, a resumable result store, local
process-pool and Ray backends, and the plot. `fluids-bench sweep` is the command line."""
