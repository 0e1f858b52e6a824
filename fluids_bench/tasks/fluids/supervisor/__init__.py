"""FLUIDS' four-level supervisor: behaviour, nominal trajectory, velocity, control.

`behavior` (which movement), `trajectory` (route curves, OMPL planning and recovery),
`velocity` (the CSP planner, which also applies the pedestrians' crosswalk rules), `control`
(PID for cars and pedestrians), wired together for every agent in `stack`.
"""
