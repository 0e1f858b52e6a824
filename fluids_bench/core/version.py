"""The package's version, on the ground floor so that every floor can read it (snapshots
record it)."""

__version__ = "0.1.0"
