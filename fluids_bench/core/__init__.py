"""What several tasks share: the supervisor protocol, argument validation, raster drawing.

Nothing task-specific lives here; a task imports `core`, never another task.
"""
