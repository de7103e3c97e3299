"""The Fetch tasks on MJX (`envs/fetch_mjx.py`): each model edit is needed and is all MJX
needs, Slide is refused with MJX's own reason, and Reach on MJX follows the native reference
(one MJX compile, about a minute on a CPU)."""

from __future__ import annotations

from pathlib import Path

import jax
import mujoco
import numpy as np
import pytest
from mujoco.mjx._src import collision_driver  # noqa: E402  (MJX's own pair list)

from mjx_skills.config import EnvConfig
from mjx_skills.core import files
from mjx_skills.envs import make
from mjx_skills.envs.fetch import load_model
from mjx_skills.envs.fetch_mjx import (
    MJX_EDITS,
    MJX_REFUSALS,
    ROBOT_PREFIX,
    deviations,
    edit_for_mjx,
    lockstep,
    resolve_physics,
    with_start,
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


PARITY = Path(__file__).resolve().parents[2] / "benchmarks/results/fetch_mjx_parity.jsonl"


def test_reach_on_mjx_follows_the_native_reference():
    """Reach, without contact: MJX on the edited model, from the native setup's start with
    the same random actions, stays near the native backend on the unedited model. The bound
    is 3x the largest position deviation that benchmarks/fetch_mjx_parity.py measured over
    50 steps (its committed row), plus 1 mm for another device's float32."""
    from mjx_skills.methods import check_task

    row = next(r for r in files.read_jsonl(PARITY) if r["task"] == "fetch_reach")
    bound = 3 * row["mjx"]["position"] + 1e-3
    native = make("fetch_reach", physics="native")
    on_mjx = with_start(
        make("fetch_reach", physics="mjx"), native.robot.start_qpos, native.robot.start_qvel
    )
    assert on_mjx.backend.name == "mjx" and on_mjx.backend.compiler_options
    out = lockstep({"native": native, "mjx": on_mjx}, jax.random.PRNGKey(1), 2, 10)
    found = deviations(out["native"], out["mjx"], native)
    assert found["position"] < bound, (found, bound)
    assert np.abs(out["native"]["obs"] - out["mjx"]["obs"]).max() > 0  # two backends ran
    for task in ("fetch_reach", "fetch_push", "fetch_pick_and_place"):  # a run may use MJX
        check_task("ddpg_her", task, {}, EnvConfig(physics="mjx"))
