"""FLUIDS' four-level supervisor: behaviour, nominal trajectory, velocity, control."""
