"""FLUIDS' step rules, written once, on B worlds' rows.

Every face of FLUIDS calls these modules: `FluidsEnv` with B = 1 (its own arrays seen as one
row), the vector env with its B worlds' rows, the PettingZoo env with one row per live agent.
No face restates a rule (`tests/tasks/fluids/test_rules_written_once.py` fails if one does).

* `rules`: what an agent did in a step (collision, rule broken, arrival, success, failure,
  termination) and its reward, for every `reward_version`.
* `actions`: what the agents do for actions at every level and scale (the supervisor filling
  the levels below), and the scale maps between physical and normalised actions.
* `labels`: the supervisor's label of an agent at every level and scale, typed like an action.
"""
