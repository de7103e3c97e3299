"""Forward kinematics of xml/baxter.xml against the URDF's reference hand positions."""

import mujoco
import numpy as np
import pytest

from mjx_skills.envs.baxter import XML_DIR

# (joint angles s0 s1 e0 e1 w0 w1 w2, hand position in the torso frame), from
# reference/baxter-kinematics.md.
POSES = {
    "neutral": ([0, -0.55, 0, 0.75, 0, 1.26, 0], [0.6339, -0.8289, 0.2194]),
    "untuck": ([0.08, -1.0, 1.19, 1.94, -0.67, 1.03, 0.50], [0.5712, -0.1808, 0.2712]),
    "zero": ([0] * 7, [0.7975, -0.9925, 0.3210]),
}


@pytest.mark.parametrize("pose", list(POSES))
def test_hand_position_matches_urdf(pose):
    model = mujoco.MjModel.from_xml_path(str(XML_DIR / "baxter.xml"))
    data = mujoco.MjData(model)
    joints, expected = POSES[pose]
    data.qpos[:7] = joints
    mujoco.mj_kinematics(model, data)
    hand = data.body("right_hand").xpos
    np.testing.assert_allclose(hand, expected, atol=1e-3)


def test_joint_limits_match_urdf():
    model = mujoco.MjModel.from_xml_path(str(XML_DIR / "baxter.xml"))
    np.testing.assert_allclose(model.jnt_range[model.joint("s1").id], [-2.147, 1.047])
    np.testing.assert_allclose(model.jnt_range[model.joint("e1").id], [-0.05, 2.618])
    np.testing.assert_allclose(model.dof_damping[:7], 0.7)
