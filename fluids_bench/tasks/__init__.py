"""One folder per task: its world (simulator), its algorithmic supervisor and its env adapters."""
