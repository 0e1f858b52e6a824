"""The three-level decision DAG of ch. 4 (the on-policy counter-example) and its greedy supervisor."""
