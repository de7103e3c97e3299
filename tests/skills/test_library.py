"""The skill library's machinery on constructed data: vmapped fits, memories, batched skill
functions, the artifact on disk (save, load, refusals)."""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.config import DDPGConfig, LibraryConfig
from mjx_skills.core import files
from mjx_skills.envs.baxter import OBS_GRIP, OBS_OBJECT, OBS_REL
from mjx_skills.skills import fit, library

SMALL = LibraryConfig(
    model_hidden=(16, 16),
    classifier_hidden=(8,),
    fit_batch=32,
    fit_epochs=40,
    patience=100,
    samples=512,
)
OBS, GOAL = 25, 3


def synthetic(key, K=2, N=512):
    """Inputs (K, N, .) with a known answer: y = W_k x (dynamics), label = x0 + x1 > 0."""
    k_o, k_g, k_w = jax.random.split(key, 3)
    o = jax.random.normal(k_o, (K, N, OBS))
    g = jax.random.normal(k_g, (K, N, GOAL))
    w = jax.random.normal(k_w, (K, OBS + GOAL, OBS)) / 5.0
    y = jnp.einsum("kni,kio->kno", jnp.concatenate([o, g], -1), w)
    label = (o[..., 0] + o[..., 1] > 0).astype(jnp.float32)
    return o, g, y, label


def split(o, g, y, dims, n_val=64):
    w = jnp.ones(o.shape[:2])
    part = lambda a, b: {
        "o": o[:, a:b],
        "g": g[:, a:b],
        "y": y[:, a:b],
        "w": w[:, a:b],
        "dims": dims,
    }
    return part(0, o.shape[1] - n_val), part(o.shape[1] - n_val, o.shape[1])


@pytest.fixture(scope="module")
def dynamics_fit():
    o, g, y, _ = synthetic(jax.random.PRNGKey(0))
    dims = jnp.ones((2, OBS))
    train, val = split(o, g, y, dims)
    keys = jax.random.split(jax.random.PRNGKey(1), 2)
    params, _ = fit.init_models(keys, SMALL, OBS, GOAL)
    loss = fit.dynamics_loss(OBS, SMALL.model_hidden)
    best, history = fit.fit(params, train, val, loss, 3e-3, SMALL, keys)
    return params, best, history, (train, val, loss, keys)


def test_fit_drives_the_loss_down_on_a_known_answer(dynamics_fit):
    _, _, history, _ = dynamics_fit
    first, last = np.array(history[0]["val"]), np.array(history[-1]["val"])
    assert np.all(last < 0.2 * first), (first, last)


def test_vmapped_fit_equals_fitting_each_skill_alone(dynamics_fit):
    params, best, _, (train, val, loss, keys) = dynamics_fit
    config = dataclasses.replace(SMALL, fit_epochs=5)
    stacked, _ = fit.fit(params, train, val, loss, 3e-3, config, keys)
    for k in range(2):
        one = lambda t, k=k: jax.tree.map(lambda x: x[k : k + 1], t)
        alone, _ = fit.fit(one(params), one(train), one(val), loss, 3e-3, config, keys[k : k + 1])
        chex.assert_trees_all_close(alone, one(stacked), rtol=1e-4, atol=1e-5)


def test_a_split_smaller_than_one_batch_fits_as_one_batch():
    """build_library --samples 100 with the default fit_batch 256 once failed in a reshape."""
    o, g, y, _ = synthetic(jax.random.PRNGKey(4), N=100)
    train, val = split(o, g, y, jnp.ones((2, OBS)), n_val=10)
    keys = jax.random.split(jax.random.PRNGKey(5), 2)
    params, _ = fit.init_models(keys, SMALL, OBS, GOAL)
    config = dataclasses.replace(SMALL, fit_batch=256, fit_epochs=30)
    loss = fit.dynamics_loss(OBS, SMALL.model_hidden)
    _, history = fit.fit(params, train, val, loss, 3e-3, config, keys)
    assert np.all(np.array(history[-1]["train"]) < np.array(history[0]["train"]))


def test_classifier_fit_separates_a_known_boundary():
    o, g, _, label = synthetic(jax.random.PRNGKey(2))
    train, val = split(o, g, label, jnp.ones((2, OBS)))
    keys = jax.random.split(jax.random.PRNGKey(3), 2)
    _, params = fit.init_models(keys, SMALL, OBS, GOAL)
    loss = fit.classifier_loss(SMALL.classifier_hidden)
    best, _ = fit.fit(params, train, val, loss, 1e-2, SMALL, keys)
    from mjx_skills.core.nets import SuccessClassifier

    logits = jax.vmap(SuccessClassifier(SMALL.classifier_hidden).apply)(best, val["o"], val["g"])
    for k in range(2):
        assert fit.auc(np.asarray(logits[k]), np.asarray(val["y"][k])) > 0.97


def test_auc_of_known_rankings():
    assert fit.auc(np.array([0.1, 0.4, 0.35, 0.8]), np.array([0, 0, 1, 1])) == 0.75
    assert fit.auc(np.array([0.5, 0.5]), np.array([0, 1])) == 0.5
    assert np.isnan(fit.auc(np.array([0.5, 0.7]), np.array([1, 1])))


def test_start_counts_split_the_runs():
    assert fit.start_counts(1000, 1, 3, 0.5) == (250, 500, 250)
    assert sum(fit.start_counts(999, 0, 3, 0.6)) == 999
    assert fit.start_counts(10, 0, 1, 0.5) == (10,)


# ---------------------------------------------------------------------- the pytree
@pytest.fixture(scope="module")
def constructed():
    """A 2-skill library (transit, grasp) with random networks and known memories."""
    names = ("transit", "grasp")
    lib = library.empty_like(names, DDPGConfig(), SMALL, memory_size=4)
    rng = np.random.default_rng(0)
    keys = rng.normal(size=(2, 4, OBS + GOAL)).astype(np.float32)
    nxt = rng.normal(size=(2, 4, OBS)).astype(np.float32)
    state_mask = np.zeros((2, OBS), bool)
    state_mask[0, :3] = True  # transit changes the grip only
    state_mask[1, :] = True
    key_mask = np.zeros((2, OBS + GOAL), bool)
    key_mask[0, [0, 1, 2, 25, 26, 27]] = True
    key_mask[1, :] = True
    valid = np.array([[True, True, True, False], [True] * 4])
    return lib.replace(
        memory_keys=jnp.asarray(keys),
        memory_next=jnp.asarray(nxt),
        state_mask=jnp.asarray(state_mask),
        memory_key_mask=jnp.asarray(key_mask),
        memory_valid=jnp.asarray(valid),
    )


def test_recall_returns_the_exact_neighbour_over_the_skills_own_dimensions(constructed):
    lib = constructed
    stored = np.asarray(lib.memory_keys)
    query = stored[0, 1].copy()
    query[3:25] += 50.0  # dimensions transit does not compare: far off, and ignored
    obs, goal = jnp.asarray(query[None, :OBS]), jnp.asarray(query[None, OBS:])
    got = np.asarray(lib.recall(jnp.array([0]), obs, goal))[0]
    want = np.asarray(lib.memory_next[0, 1])
    np.testing.assert_allclose(got[OBS_GRIP], want[OBS_GRIP], rtol=1e-6)
    # What transit does not change is copied from the query, and object - grip recomputed.
    np.testing.assert_allclose(got[OBS_OBJECT], query[OBS_OBJECT], rtol=1e-6)
    np.testing.assert_allclose(got[OBS_REL], query[OBS_OBJECT] - want[OBS_GRIP], rtol=1e-5)
    # An invalid slot is never returned, even when it is the nearest.
    near_invalid = stored[0, 3]
    got = lib.recall(
        jnp.array([0]), jnp.asarray(near_invalid[None, :OBS]), jnp.asarray(near_invalid[None, OBS:])
    )
    assert not np.allclose(np.asarray(got)[0, :3], np.asarray(lib.memory_next[0, 3, :3]))


def test_goal_anchored_recall_carries_the_neighbours_offset_from_its_goal(constructed):
    """anchor = "goal": the grip (transit) ends where the neighbour ended relative to its own
    goal, moved to the query's goal; the model's change is added to the goal, not the start."""
    lib = constructed.replace(config=dataclasses.replace(SMALL, anchor="goal"))
    stored = np.asarray(lib.memory_keys)
    query = stored[0, 1].copy()
    query[OBS:] += np.array([0.01, -0.02, 0.005], np.float32)  # nearest is still slot 1
    obs, goal = jnp.asarray(query[None, :OBS]), jnp.asarray(query[None, OBS:])
    got = np.asarray(lib.recall(jnp.array([0]), obs, goal))[0]
    nb = np.asarray(lib.memory_next[0, 1])
    np.testing.assert_allclose(
        got[OBS_GRIP], nb[OBS_GRIP] - stored[0, 1, OBS:] + query[OBS:], atol=1e-5
    )
    np.testing.assert_allclose(got[OBS_OBJECT], query[OBS_OBJECT], rtol=1e-6)  # not moved
    # The model: zero networks predict the mean change, measured from the goal.
    zero = jax.tree.map(jnp.zeros_like, lib.dynamics)
    d_mean = np.asarray(lib.delta_norm.mean)
    for anchor, base in (("start", query[:3]), ("goal", query[OBS:])):
        m = lib.replace(dynamics=zero, config=dataclasses.replace(SMALL, anchor=anchor))
        pred = np.asarray(m.next_state(jnp.array([0]), obs, goal))[0]
        np.testing.assert_allclose(pred[OBS_GRIP], base + d_mean[0, :3], atol=1e-5)


def test_at_goal_moves_only_what_the_skill_moves(constructed):
    rng = np.random.default_rng(2)
    obs = jnp.asarray(rng.normal(size=(2, OBS)).astype(np.float32))
    goal = jnp.asarray(rng.normal(size=(2, GOAL)).astype(np.float32))
    got = np.asarray(constructed.at_goal(jnp.array([0, 1]), obs, goal))
    # transit: the grip at the goal, the cube where it was; grasp: both at the goal.
    np.testing.assert_allclose(got[0, OBS_GRIP], goal[0], rtol=1e-6)
    np.testing.assert_allclose(got[0, OBS_OBJECT], obs[0, OBS_OBJECT], rtol=1e-6)
    np.testing.assert_allclose(got[1, OBS_OBJECT], goal[1], rtol=1e-6)
    np.testing.assert_allclose(got[:, OBS_REL], got[:, OBS_OBJECT] - got[:, OBS_GRIP], atol=1e-6)
    np.testing.assert_allclose(got[:, 11:], np.asarray(obs)[:, 11:], rtol=1e-6)


def test_each_env_runs_its_own_skill(constructed):
    lib = constructed
    rng = np.random.default_rng(1)
    obs = jnp.asarray(rng.normal(size=(4, OBS)).astype(np.float32))
    goal = jnp.asarray(rng.normal(size=(4, GOAL)).astype(np.float32))
    skill = jnp.array([0, 1, 1, 0])
    batched = lib.policy_action(skill, obs, goal)
    probs = lib.success_prob(skill, obs, goal)
    param = jnp.asarray(rng.uniform(-1, 1, size=(4, 3)).astype(np.float32))
    goals = lib.goal_from_param(skill, param, obs)
    for i, k in enumerate(np.asarray(skill)):
        one = jnp.full((1,), k)
        np.testing.assert_allclose(
            batched[i], lib.policy_action(one, obs[i : i + 1], goal[i : i + 1])[0], atol=1e-5
        )
        np.testing.assert_allclose(
            probs[i], lib.success_prob(one, obs[i : i + 1], goal[i : i + 1])[0], atol=1e-5
        )
        env = lib.envs[k]
        np.testing.assert_allclose(
            goals[i], env.goal_from_param(param[i, : env.param_dim], obs[i]), atol=1e-6
        )
    assert not np.allclose(batched[0], lib.policy_action(jnp.array([1]), obs[:1], goal[:1])[0])


def test_reduced_libraries_by_name(constructed):
    with pytest.raises(ValueError, match="valid: SL1, SL2, SL3"):
        library.library_skills("SL9")
    full = library.empty_like(library.LIBRARIES["SL1"], DDPGConfig(), SMALL, memory_size=2)
    sl3 = library.subset(full, "SL3")
    assert sl3.names == ("transit", "transfer") and sl3.memory_keys.shape[0] == 2
    with pytest.raises(ValueError, match="this library has: transit, grasp"):
        constructed.index("transfer")


# ---------------------------------------------------------------------- on disk
def test_save_load_round_trip_and_refusals(constructed, tmp_path):
    path = library.save(constructed, tmp_path / "lib", {"memory_size": 4, "note": "test"})
    loaded, manifest = library.load(path)
    assert loaded.names == constructed.names and manifest["note"] == "test"
    chex.assert_trees_all_equal(loaded, constructed)
    with pytest.raises(FileExistsError, match="never overwritten"):
        library.save(constructed, path, {"memory_size": 4})
    with pytest.raises(FileNotFoundError, match="make skills"):
        library.load(tmp_path / "missing")
    raw = json.loads((path / "manifest.json").read_text())
    (path / "manifest.json").write_text(json.dumps({**raw, "format": 0}))
    with pytest.raises(ValueError, match="rebuild"):
        library.load(path)
    (path / "manifest.json").unlink()
    with pytest.raises(ValueError, match="half-written"):
        library.load(path)


def test_a_library_whose_arrays_changed_on_disk_is_refused(constructed, tmp_path, caplog):
    """Arrays that still decode, to other numbers (another library's, copied in), are
    refused by the digest that `save` put in the manifest, naming the library; a flipped
    byte is refused too (by the digest, or earlier by the decoder, depending on where it
    lands); a library saved before digests were recorded loads with a warning."""
    path = library.save(constructed, tmp_path / "lib", {"memory_size": 4})
    assert library.read_manifest(path)["digest"] == files.tree_sha256(constructed)
    other = jax.tree.map(
        lambda x: x + 1 if jnp.issubdtype(x.dtype, jnp.floating) else x, constructed
    )
    elsewhere = library.save(other, tmp_path / "other", {"memory_size": 4})
    shutil.move(path / "arrays", tmp_path / "arrays.good")
    shutil.copytree(elsewhere / "arrays", path / "arrays")
    with pytest.raises(ValueError, match=rf"{path}: the library's arrays are damaged"):
        library.load(path)
    shutil.rmtree(path / "arrays")
    shutil.move(tmp_path / "arrays.good", path / "arrays")
    stored = [p for p in (path / "arrays").rglob("*") if p.is_file()]
    data = max(stored, key=lambda p: p.stat().st_size)
    good = data.read_bytes()
    damaged = bytearray(good)
    damaged[len(good) // 2] ^= 0xFF
    data.write_bytes(bytes(damaged))
    with pytest.raises(
        ValueError, match=rf"{path}: the library's arrays (are damaged|do not load)"
    ):
        library.load(path)
    data.write_bytes(good)
    raw = json.loads((path / "manifest.json").read_text())
    del raw["digest"]
    (path / "manifest.json").write_text(json.dumps(raw))
    with caplog.at_level(logging.WARNING):
        loaded, _ = library.load(path)
    chex.assert_trees_all_equal(loaded, constructed)
    assert "no digest" in caplog.text


@pytest.mark.parametrize(
    ("field", "value"),
    [("anchor", "goal"), ("anchor", "start"), ("model_hidden", [8]), ("memory_size", 3)],
)
def test_a_manifest_whose_defining_fields_were_edited_is_refused(
    constructed, tmp_path, field, value
):
    """The arrays' digest cannot see the manifest's own fields, which say how the arrays are
    read (the anchor, the widths): its `definition` digest does."""
    path = library.save(constructed, tmp_path / "lib", {"memory_size": 4})
    raw = json.loads((path / "manifest.json").read_text())
    edited = {**raw, "library": {**raw["library"]}}
    where = edited if field == "memory_size" else edited["library"]
    if where[field] == value:
        return  # the value it was built with: nothing edited
    where[field] = value
    (path / "manifest.json").write_text(json.dumps(edited))
    with pytest.raises(ValueError, match=rf"{path}: manifest.json's .* \(edited since\)"):
        library.load(path)


def test_the_committed_libraries_carry_the_digest_of_their_arrays(caplog):
    for directory in sorted(library.DEFAULT_DIR.parent.glob("skill_library*")):
        if (directory / "manifest.json").exists():
            assert {"digest", "definition"} <= set(library.read_manifest(directory)), directory
            with caplog.at_level(logging.WARNING):
                library.load(directory)  # verified: raises if its arrays differ
            assert "no digest" not in caplog.text, directory


@pytest.mark.parametrize("rows", [10, 600, 5000])
@pytest.mark.parametrize("skills_used", [(0, 1, 2), (2,)])
def test_rows_grouped_by_skill_get_their_own_skills_network(rows, skills_used):
    """apply_per_row equals running each row through its own skill's weights, whether it
    selects (few rows) or groups rows by skill into blocks (many; skills may be unused)."""
    from mjx_skills.core.grouped import apply_per_row

    rng = np.random.default_rng(rows)
    weights = jnp.asarray(rng.normal(size=(3, 5, 4)), jnp.float32)
    bias = jnp.asarray(rng.normal(size=(3, 4)), jnp.float32)
    skill = jnp.asarray(rng.choice(skills_used, rows), jnp.int32)
    x = jnp.asarray(rng.normal(size=(rows, 5)), jnp.float32)
    fn = lambda p, x: jnp.tanh(x @ p[0] + p[1])
    got = jax.jit(lambda s, x: apply_per_row(fn, (weights, bias), s, x))(skill, x)
    want = np.tanh(np.einsum("ri,rio->ro", x, np.asarray(weights)[skill]) + np.asarray(bias)[skill])
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_the_scenes_digest_covers_the_one_cube_scenes_and_their_includes_only():
    """The skills' physics: every one-cube scene and what it includes; the two-cube scenes
    (added after the committed library) do not make it stale."""
    names = {p.name for p in library.scene_files()}
    assert {
        "scene_pick_move.xml",
        "scene_put_in_container.xml",
        "baxter.xml",
        "table.xml",
        "object.xml",
    } <= names
    assert not names & {"object2.xml", "scene_pick_move_two.xml", "scene_two_in_container.xml"}
    manifest = library.read_manifest(library.DEFAULT_DIR)
    assert manifest["scenes"] == library.scenes_digest()


def test_a_library_from_other_scenes_or_code_is_flagged_with_the_rebuild_command(tmp_path, caplog):
    """The manifest records version, commit and the scenes' digest; a library built in
    other scenes (the cube got a floor since the old one) or by another version is warned
    about with the command that rebuilds it; one that matches is read silently."""
    made = library.provenance()
    assert made["scenes"] == library.scenes_digest() and len(made["scenes"]) == 16
    assert made["commit"] == "unknown" or len(made["commit"].split("+")[0]) == 40
    manifest = {"complete": True, "format": library.FORMAT, **made}
    for name, changes, reason in (
        ("current", {}, None),
        ("old_scenes", {"scenes": "0" * 16}, "other scenes"),
        ("no_record", {"scenes": None}, "before the scenes"),
        ("other_version", {"version": "0.0.1"}, "version 0.0.1"),
    ):
        (tmp_path / name).mkdir()
        (tmp_path / name / "manifest.json").write_text(json.dumps({**manifest, **changes}))
        caplog.clear()
        library.read_manifest(tmp_path / name)
        if reason is None:
            assert not caplog.records
        else:
            assert (
                reason in caplog.text and "python -m mjx_skills.build_library --out" in caplog.text
            )
