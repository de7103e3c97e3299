"""gymnasium-robotics 1.4.2's own Fetch envs, made to run on mujoco 4.0: the reference that
`tests/envs/test_fetch.py` compares the JAX Fetch tasks with. Nothing else imports this module;
the JAX envs never run gymnasium-robotics' code.

Why a patch: gymnasium-robotics' `utils/mujoco_utils.py` checks a joint's type with
`assert joint_type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)`
(`set_joint_qpos`, `set_joint_qvel`, `get_joint_qpos`, `get_joint_qvel`), where `joint_type`
is a numpy int from `model.jnt_type`. Under mujoco 4.0 an `mjtJoint` member compared with a
numpy int is False (`mjJNT_SLIDE == np.int32(2)` is False, although `np.int32(2) ==
mjJNT_SLIDE` is True), and `in` compares the tuple's members on the left: the assertion fails
for every hinge and slide joint, so no Fetch env can even be built (`_env_setup` sets the
slide joints), let alone observed (`robot_get_obs` reads every robot joint).

The patch changes only that: `reference_env` builds the original env class through a
subclass whose `_utils` (the module the env calls its helpers through) is a copy of
`mujoco_utils` whose `mujoco` is the real module but for `mjtJoint`, a namespace of the same
members as plain ints. Their module and every other use of it stay as they are.
"""

from __future__ import annotations

import functools
import importlib
import types

import mujoco

from mjx_skills.envs.fetch_tasks import FETCH_TASKS

_MODULES = {
    "fetch_reach": "reach",
    "fetch_push": "push",
    "fetch_slide": "slide",
    "fetch_pick_and_place": "pick_and_place",
}
"""Registry name -> gymnasium_robotics.envs.fetch.<module> (class Mujoco<Task>Env)."""


class _MujocoIntJointTypes(types.ModuleType):
    """The `mujoco` module as seen by the patched helpers: `mjtJoint`'s members as ints,
    every other attribute the real module's."""

    def __init__(self) -> None:
        super().__init__("mujoco")
        names = [n for n in dir(mujoco.mjtJoint) if n.startswith("mjJNT_")]
        self.mjtJoint = types.SimpleNamespace(
            **{n: int(getattr(mujoco.mjtJoint, n)) for n in names}
        )

    def __getattr__(self, name: str):  # only called for what __init__ did not set
        return getattr(mujoco, name)


@functools.cache
def patched_utils() -> types.ModuleType:
    """A copy of gymnasium_robotics.utils.mujoco_utils whose functions see
    `_MujocoIntJointTypes` as `mujoco` (and each other's copies)."""
    from gymnasium_robotics.utils import mujoco_utils

    namespace = dict(vars(mujoco_utils))
    namespace["mujoco"] = _MujocoIntJointTypes()
    for name, value in vars(mujoco_utils).items():
        if isinstance(value, types.FunctionType) and value.__module__ == mujoco_utils.__name__:
            namespace[name] = types.FunctionType(
                value.__code__, namespace, value.__name__, value.__defaults__, value.__closure__
            )
    module = types.ModuleType(mujoco_utils.__name__ + "_int_joint_types", mujoco_utils.__doc__)
    module.__dict__.update(namespace)
    return module


def reference_class(task: str) -> type:
    """gymnasium-robotics' `Mujoco<Task>Env` for a registry name, unpatched."""
    module = importlib.import_module(f"gymnasium_robotics.envs.fetch.{_MODULES[task]}")
    return getattr(module, f"Mujoco{FETCH_TASKS[task].__name__}Env")


@functools.cache
def _patched_class(task: str) -> type:
    original = reference_class(task)
    utils = property(lambda self: patched_utils(), lambda self, value: None)
    return type(original.__name__, (original,), {"_utils": utils, "__module__": __name__})


def reference_env(task: str, **kwargs):
    """gymnasium-robotics' env of `task` ('fetch_push', ...), built and run with the patched
    joint-type checks; kwargs go to its constructor (reward_type, render_mode, ...). No
    TimeLimit: gymnasium.make would add its 50 steps."""
    return _patched_class(task)(**kwargs)
