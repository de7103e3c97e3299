"""The Fetch tasks on MJX (`envs/fetch_mjx.py`): each model edit is needed and is all MJX
needs, and Slide is refused with MJX's own reason. Nothing here compiles an MJX step (see
docs/simulation.md: the Fetch env step's MJX compile, on a CPU, is still open)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from mujoco.mjx._src import collision_driver  # noqa: E402  (MJX's own pair list)

from mjx_skills.config import EnvConfig
from mjx_skills.envs import make
from mjx_skills.envs.fetch import load_model
from mjx_skills.envs.fetch_mjx import (
    MJX_EDITS,
    MJX_REFUSALS,
    ROBOT_PREFIX,
    edit_for_mjx,
    resolve_physics,
)
from mjx_skills.envs.physics import mjx

MJX_SCENES = ("reach", "push", "pick_and_place")


def _array_fields(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    return {
        name: getattr(model, name)
        for name in dir(model)
        if not name.startswith("_") and isinstance(getattr(model, name), np.ndarray)
    }


@pytest.mark.parametrize("scene", MJX_SCENES)
def test_each_mjx_edit_is_needed_and_together_they_are_enough(scene):
    model = load_model(scene, has_object=scene != "reach")
    with pytest.raises(NotImplementedError, match=r"MESH\) margin/gap not implemented"):
        mjx.put_model(model)
    before = {k: v.copy() for k, v in _array_fields(model).items()}
    edited = edit_for_mjx(model)
    mjx.put_model(edited)
    for name, value in _array_fields(model).items():  # the argument is left as it was
        np.testing.assert_array_equal(value, before[name], err_msg=name)
    changed = {
        name
        for name, value in _array_fields(edited).items()
        if value.shape != before[name].shape or not np.array_equal(value, before[name])
    }
    assert changed == {"geom_margin", "geom_contype", "geom_conaffinity"}, changed
    assert int(np.sum(edited.geom_margin != model.geom_margin)) == 17
    assert not edited.geom_margin.any()
    # Without the margin edit put_model refuses; without the self-collision one MJX keeps the
    # arm's mesh-mesh pairs (whose compile exhausts a CPU's memory); each does its part only.
    margins, self_collisions = MJX_EDITS
    with pytest.raises(NotImplementedError, match=r"MESH\) margin/gap not implemented"):
        mjx.put_model(edit_for_mjx(model, (self_collisions,)))
    pairs = {
        label: {(g1, g2) for g1, g2, _ in collision_driver.geom_pairs(edit_for_mjx(model, edits))}
        for label, edits in (("all", MJX_EDITS), ("margins only", (margins,)))
    }
    robot = [model.body(b).name.startswith(ROBOT_PREFIX) for b in model.geom_bodyid]
    mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
    assert any(mesh[g1] and mesh[g2] for g1, g2 in pairs["margins only"])
    assert not any(mesh[g1] and mesh[g2] for g1, g2 in pairs["all"])
    # Every pair but the robot's against itself still collides.
    assert pairs["all"] == {(a, b) for a, b in pairs["margins only"] if not robot[a] & robot[b]}


def test_slide_is_refused_on_mjx_with_mjx_reason():
    slide = edit_for_mjx(load_model("slide", has_object=True))
    with pytest.raises(NotImplementedError, match=r"CYLINDER, \S*MESH\) collisions not") as err:
        mjx.put_model(slide)
    reason = str(err.value).replace("mjtGeom.mjGEOM_", "").rstrip(".")  # "(CYLINDER, MESH) ..."
    assert reason in MJX_REFUSALS["slide"], (reason, MJX_REFUSALS["slide"])
    with pytest.raises(ValueError, match=r"\(CYLINDER, MESH\) collisions not implemented"):
        make("fetch_slide", physics="mjx")
    from mjx_skills.methods import check_task

    with pytest.raises(ValueError, match="use physics='native'"):
        check_task("ddpg_her", "fetch_slide", {}, EnvConfig(physics="mjx"))
    # 'auto' is native for every scene on every device until the MJX path is measured.
    for scene in ("reach", "push", "slide", "pick_and_place"):
        for device in ("cpu", "gpu"):
            assert resolve_physics(scene, "auto", device) == "native"


@pytest.mark.parametrize("task", ["fetch_reach", "fetch_push", "fetch_pick_and_place"])
def test_the_scenes_mjx_loads_are_refused_until_measured(task):
    """put_model takes the edited model, but the MJX path is not shown to compile and run
    (its scanned step's compile ran out of memory on a CPU): refused with that reason, before any run."""
    from mjx_skills.methods import check_task

    with pytest.raises(ValueError, match="not shown to run yet"):
        make(task, physics="mjx")
    with pytest.raises(ValueError, match=r"Fetch\w+: .*fetch_mjx_parity.jsonl"):
        check_task("ddpg_her", task, {}, EnvConfig(physics="mjx"))
