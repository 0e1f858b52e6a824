"""Gymnasium and PettingZoo adapters over the simulators and supervisors."""
