"""FLUIDS: a first-order multi-agent urban-intersection driving simulator (`sim/`), its
four-level supervisor (`supervisor/`), and the Gymnasium and PettingZoo envs over them."""
