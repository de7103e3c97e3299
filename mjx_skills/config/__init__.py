"""Frozen configuration dataclasses, one docstring per field (parsed by tyro on the CLI).

Defaults follow the thesis (Table 6.1) and the original code where the thesis is silent;
each departure is said in the field's docstring. A leaf package: it imports nothing from the
rest of the package (task and method names are checked where envs and methods are made).
"""

from mjx_skills.config.checks import SEED_LIMIT, check_numbers, checked_value
from mjx_skills.config.ddpg import DDPGConfig
from mjx_skills.config.env import LIBRARIES, PHYSICS, EnvConfig, Library, Physics
from mjx_skills.config.library import LIBRARY_BUILD, LibraryConfig, build_config
from mjx_skills.config.search import PASConfig, SearchConfig
from mjx_skills.config.train import TrainConfig

__all__ = [
    "DDPGConfig",
    "EnvConfig",
    "LIBRARIES",
    "LIBRARY_BUILD",
    "Library",
    "LibraryConfig",
    "PASConfig",
    "PHYSICS",
    "Physics",
    "SEED_LIMIT",
    "SearchConfig",
    "TrainConfig",
    "build_config",
    "check_numbers",
    "checked_value",
]
