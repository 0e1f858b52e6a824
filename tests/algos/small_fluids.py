"""A small FLUIDS-v0 scene at the velocity level on a 16-ray quasi-LIDAR: cheap episodes for the
algorithm tests."""

SMALL_FLUIDS = {
    "env_id": "FLUIDS-v0",
    "env_kwargs": {
        "action_level": "velocity",
        "obs_type": "qlidar",
        "lidar_rays": 16,
        "num_cars": 2,
        "num_pedestrians": 1,
    },
}
