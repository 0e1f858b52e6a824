"""sim/layout."""
