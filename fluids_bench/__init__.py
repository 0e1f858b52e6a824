"""fluids-bench: imitation-learning environments centred on the FLUIDS driving simulator.

Importing the package registers every environment id with Gymnasium, so
`gym.make("FLUIDS-v0")` works after `import fluids_bench`.
"""

from fluids_bench.core.numba_cache import use_user_cache_dir

use_user_cache_dir()  # before any module that compiles kernels is imported

from fluids_bench.core.version import __version__  # noqa: E402
from fluids_bench.registration import register_envs  # noqa: E402

register_envs()

__all__ = ["__version__", "register_envs"]
