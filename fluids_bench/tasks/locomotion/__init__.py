"""MuJoCo locomotion (ch. 3): Gymnasium's v5 envs with deterministic supervisors."""
