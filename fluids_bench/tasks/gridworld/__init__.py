"""The stochastic gridworld of ch. 3 with an exact value-iteration supervisor."""
