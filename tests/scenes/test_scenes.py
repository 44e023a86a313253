"""Every scene compiles and steps without a MuJoCo warning (mujoco_menagerie's habit)."""

import mujoco
import numpy as np
import pytest

from calibench.scenes import scenes
from calibench.scenes.checkerboard import Chessboard

SCENES = scenes()


def test_every_machine_has_its_default_scene():
    assert {"belt_stage", "vision_stage", "probe_scanner", "stewart"} <= set(SCENES)
    assert {"arm_mjcf/arm-cmm", "arm_mjcf/ur10"} <= set(SCENES)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_scene_compiles_and_steps_without_warnings(name):
    xml, assets = SCENES[name]()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    data = mujoco.MjData(model)
    for _ in range(500):
        mujoco.mj_step(model, data)
    warnings = {
        mujoco.mjtWarning(i).name: data.warning[i].number
        for i in range(len(data.warning))
        if data.warning[i].number
    }
    assert warnings == {}
    assert np.isfinite(data.qpos).all()


def test_chessboard_corners_and_texture_agree():
    board = Chessboard(cols=9, rows=6, square_mm=50.0, margin_mm=25.0)
    tex = board.texture(px_per_square=64)
    assert tex.shape == (7 * 64 + 64, 10 * 64 + 64, 3)
    c = board.corners_mm()
    assert c.shape == (54, 3)
    np.testing.assert_array_equal(c[1] - c[0], [50, 0, 0])  # along a row: +x
    np.testing.assert_array_equal(c[9] - c[0], [0, 50, 0])  # next row: +y
    # the square before corner 0 is black, the one after the last corner white (cols+rows odd)
    m, s = 32, 64
    assert tex[m + s // 2, m + s // 2, 0] == 0
    assert tex[m + 6 * s + s // 2, m + 9 * s + s // 2, 0] == 255
    assert tex[0, 0, 0] == 255  # white margin


def test_texture_margin_must_be_whole_texels():
    with pytest.raises(ValueError):
        Chessboard(square_mm=50.0, margin_mm=10.0).texture(px_per_square=4)


def _model_arrays(model) -> dict:
    out = {}
    for name in dir(model):
        if not name.startswith("_"):
            v = getattr(model, name, None)
            if isinstance(v, np.ndarray):
                out[name] = v
    return out


@pytest.mark.parametrize("arm_name", ["arm-cmm", "ur10"])
def test_as_built_arm_model_is_the_mjcf_s(arm_name):
    """An as-built arm written into the cached spec compiles to the model its MJCF gives, every
    array exactly (equal values, -0.0 and 0.0 alike; hundreds of arrays: frames, inertias,
    geoms, flags the compiler derives), for nominal and perturbed arms, rigid and sprung, one
    after another (a spec reused must not keep anything of the previous arm)."""
    import mujoco

    from calibench.scenes.arm_cmm import load_arm
    from calibench.scenes.arm_mjcf import as_built_model, build_mjcf

    arm = load_arm(arm_name)
    N = arm.n_joints
    rng = np.random.default_rng(0)
    compared = 0
    for k in range(6):
        delta = rng.normal(0, np.r_[np.tile([0.1, 0.1, 1e-3, 1e-3, 1e-3], N), 0.1, 0.1, 0.1]) * (
            k > 0
        )
        args = (
            arm,
            arm.nominal() + delta[: 5 * N].reshape(N, 5),
            np.asarray(arm.tool_mm) + delta[5 * N :],
            None if k % 2 else np.full(N, 1e5),
            np.array([2.2, -0.9, 0.35]),
            np.array([0.5, 0.5, 0.5, 0.5]),
            (np.array([0.45, 0.25, -0.15]), np.array([0.45, -0.35, -0.15])),
        )
        fast = _model_arrays(as_built_model(*args))
        parsed = _model_arrays(mujoco.MjModel.from_xml_string(build_mjcf(*args)))
        assert fast.keys() == parsed.keys()
        for name, v in parsed.items():
            assert np.array_equal(fast[name], v, equal_nan=True), f"arm {k}: {name}"
        compared += len(parsed)
    assert compared > 6 * 100


@pytest.mark.parametrize("convention", ["dh", "mdh"])
def test_joint_quaternions_are_the_joint_frames_turns(convention):
    """The MJCF's quaternions, made from half angles, turn as joint_frames' matrices do (MuJoCo's
    own quaternion-to-matrix), to 1e-15, at random angles including whole turns."""
    import mujoco

    from calibench.scenes.arm_mjcf import joint_frames, joint_quats

    rng = np.random.default_rng(2)
    alpha, theta, beta = rng.uniform(-2 * np.pi, 2 * np.pi, (3, 40))
    pre_R, _, post_R, _ = joint_frames(convention, np.ones(40), np.ones(40), alpha, theta, beta)
    pre_q, post_q = joint_quats(convention, alpha, theta, beta)
    for q, R in zip(np.r_[pre_q, post_q], np.r_[pre_R, post_R]):
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
        m = np.empty(9)
        mujoco.mju_quat2Mat(m, q)
        np.testing.assert_allclose(m.reshape(3, 3), R, rtol=0, atol=1e-15)


@pytest.mark.parametrize("arm_name", ["arm-cmm", "ur10"])
def test_a_reused_arm_twin_is_the_compiled_one(arm_name):
    """A Monte-Carlo trial's twin (``ArmSim(..., reuse=True)``: the thread's last model of the
    setup, the as-built arm written in place) against a twin compiled from scratch, for arms one
    after another, rigid and sprung: every array kinematics, inverse dynamics and rendering read
    (the massless link bodies' inertial frames aside), to 1e-15; the tool points and gravity
    torques to 1e-12; nothing a previous twin's stepping moved is kept."""
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    arm = load_arm(arm_name)
    N = arm.n_joints
    rng = np.random.default_rng(4)
    for k in range(6):
        delta = rng.normal(0, np.r_[np.tile([0.1, 0.1, 1e-3, 1e-3, 1e-3], N), 0.1, 0.1, 0.1])
        truth = ArmTruth(delta=tuple(delta), stiffness_nm_per_rad=(1e5,) * N if k % 2 else ())
        reused, compiled = ArmSim(arm, truth, reuse=True), ArmSim(arm, truth)
        heavy = compiled.model.body_mass > 0
        for name in (
            "body_pos",
            "body_quat",
            "body_mass",
            "body_inertia",
            "geom_pos",
            "geom_quat",
            "geom_size",
            "geom_rbound",
            "geom_aabb",
            "site_pos",
            "qpos_spring",
            "dof_M0",
            "jnt_stiffness",
        ):
            np.testing.assert_allclose(
                getattr(reused.model, name),
                getattr(compiled.model, name),
                rtol=0,
                atol=1e-15,
                err_msg=f"arm {k}: {name}",
            )
        for name in ("body_ipos", "body_iquat"):
            np.testing.assert_allclose(
                getattr(reused.model, name)[heavy],
                getattr(compiled.model, name)[heavy],
                rtol=0,
                atol=1e-15,
                err_msg=f"arm {k}: {name}",
            )
        q = rng.uniform(-np.pi, np.pi, (20, N))
        np.testing.assert_allclose(reused.probe_mm(q), compiled.probe_mm(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            reused.gravity_torques(q), compiled.gravity_torques(q), rtol=0, atol=1e-12
        )
        if k == 3:
            reused.settle_by_stepping(
                q[0], seconds=0.01
            )  # moves qpos_spring: the next reuse must not keep it


def test_a_link_that_becomes_a_point_is_not_written_in_place():
    """A link whose length falls below 1 um is a sphere in the MJCF, not a capsule: the model
    cannot take it in place, says so, and is left as it was."""
    from calibench.scenes.arm_cmm import load_arm
    from calibench.scenes.arm_mjcf import as_built_model, write_as_built

    arm = load_arm("arm-cmm")
    model = as_built_model(arm, arm.nominal(), np.asarray(arm.tool_mm))
    before = model.body_pos.copy()
    values = arm.nominal()
    values[2, :2] = 0.0  # joint 3's a and d: its link has no length
    assert not write_as_built(model, arm, values, np.asarray(arm.tool_mm))
    np.testing.assert_array_equal(model.body_pos, before)


def test_an_arm_s_name_is_text_in_its_mjcf():
    """Quotes, angle brackets and ampersands in an arm's name stay its name: the MJCF compiles and
    MuJoCo reads the name back (it used to end the attribute and break the XML)."""
    import dataclasses

    import mujoco

    from calibench.scenes.arm_cmm import load_arm
    from calibench.scenes.arm_mjcf import build_mjcf

    arm = dataclasses.replace(load_arm("ur10"), name='UR10" evil="<x>&')
    model = mujoco.MjModel.from_xml_string(build_mjcf(arm))
    assert model.names.split(b"\0")[0] == b'UR10" evil="<x>&'  # the model's name comes first


def test_arm_names_are_quoted_as_saxutils_quotes_them():
    """scenes/arm_mjcf.py writes an arm's name into the MJCF without importing saxutils (27 ms
    of a study worker's start): the same characters as saxutils' quoteattr, every case of it."""
    from xml.sax.saxutils import quoteattr as saxutils_quoteattr

    from calibench.scenes.arm_mjcf import quoteattr

    names = ["ur10", "a&b", "<x>", 'say "hi"', "it's", "both ' and \" here", "t\tn\nr\r", ""]
    for name in names + ["&amp;", "\"&'<>\n"]:
        assert quoteattr(name) == saxutils_quoteattr(name), name


def test_an_arm_file_saved_with_a_byte_order_mark_reads_as_without(tmp_path):
    import dataclasses
    from pathlib import Path

    from calibench.scenes.arm_cmm import load_arm

    plain = Path(__file__).resolve().parents[2] / "scenes" / "arms" / "ur10.toml"
    marked = tmp_path / "ur10.toml"
    marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    a, b = load_arm(marked), load_arm(plain)
    assert dataclasses.replace(a, source=b.source) == b
