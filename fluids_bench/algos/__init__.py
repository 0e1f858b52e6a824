"""Imitation-learning algorithms: one readable module each."""
