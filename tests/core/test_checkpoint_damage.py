"""Damaged checkpoints: changed contents, a missing digest, missing arrays or emptied files
fall back to the previous good checkpoint (or restore with a warning), and a checkpoint
newer than the whole log is not resumed from."""

from __future__ import annotations

import json
import logging

import numpy as np

from mjx_skills.training.checkpoint import Checkpoints
from mjx_skills.training.metrics_log import read_metrics
from tests.fakes import flip_byte


# ------------------------------------------------------------------ checkpoints
def test_a_checkpoint_whose_contents_changed_falls_back_to_the_previous_one(tmp_path, caplog):
    """Bytes flipped in a saved array still decode, to other numbers: the digest recorded at
    save time refuses them and the epoch before is restored."""
    tree = {"w": np.arange(4096, dtype=np.float32), "n": np.arange(3, dtype=np.int32)}
    ckpt = Checkpoints(tmp_path / "checkpoints")
    ckpt.save(1, tree)
    ckpt.save(2, {**tree, "w": tree["w"] + 1})
    assert set(json.loads((tmp_path / "checkpoints" / "digests.json").read_text())) == {"1", "2"}
    data = sorted(
        (p for p in (tmp_path / "checkpoints" / "2").rglob("*") if p.is_file()),
        key=lambda p: p.stat().st_size,
    )[-1]
    flip_byte(data)
    with caplog.at_level(logging.WARNING):
        epoch, restored = ckpt.restore(tree)
    ckpt.close()
    assert epoch == 1 and np.array_equal(restored["w"], tree["w"])
    assert list((tmp_path / "checkpoints").glob("2.corrupt-*"))
    assert "epoch 2" in caplog.text


def test_a_checkpoint_without_a_recorded_digest_restores_with_a_warning(tmp_path, caplog):
    tree = {"w": np.arange(8, dtype=np.float32)}
    ckpt = Checkpoints(tmp_path / "checkpoints")
    ckpt.save(1, tree)
    (tmp_path / "checkpoints" / "digests.json").unlink()  # as an older run's
    with caplog.at_level(logging.WARNING):
        epoch, restored = ckpt.restore(tree)
    ckpt.close()
    assert epoch == 1 and np.array_equal(restored["w"], tree["w"])
    assert "no recorded digest" in caplog.text


def test_a_checkpoint_missing_its_arrays_falls_back_and_keeps_the_good_ones(tmp_path):
    """One damaged step must not make the manager refuse, and set aside, every good one."""
    import shutil

    import jax.numpy as jnp

    from mjx_skills.training.checkpoint import Checkpoints

    tree = {"a": jnp.arange(4.0), "b": jnp.ones(3)}
    checkpoints = Checkpoints(tmp_path / "checkpoints")
    for epoch in (1, 2, 3):
        checkpoints.save(epoch, {"a": tree["a"] + epoch, "b": tree["b"]})
    checkpoints.close()
    shutil.rmtree(tmp_path / "checkpoints" / "3" / "default")
    epoch, restored = Checkpoints(tmp_path / "checkpoints").restore(tree)
    assert epoch == 2 and float(restored["a"][0]) == 2.0
    names = {p.name for p in (tmp_path / "checkpoints").iterdir()}
    assert {"1", "2"} <= names and any(n.startswith("3.corrupt-") for n in names)


def test_every_file_of_a_checkpoint_emptied_falls_back_with_a_short_message(tmp_path, caplog):
    """A zero-byte file (a full disk, a cut copy) anywhere in the newest checkpoint: the one
    before is restored, and the warning is a line, not tensorstore's 1 kB spec."""
    import shutil

    tree = {"w": np.arange(64, dtype=np.float32), "n": np.arange(3, dtype=np.int32)}
    base = tmp_path / "base"
    ckpt = Checkpoints(base / "checkpoints")
    ckpt.save(1, tree)
    ckpt.save(2, {"w": tree["w"] + 1, "n": tree["n"]})
    ckpt.close()
    files = [p.relative_to(base) for p in (base / "checkpoints" / "2").rglob("*") if p.is_file()]
    assert len(files) >= 5
    for i, rel in enumerate(files):
        copy = tmp_path / str(i)
        shutil.copytree(base, copy)
        (copy / rel).write_bytes(b"")
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            epoch, restored = Checkpoints(copy / "checkpoints").restore(tree)
        # a file the restore does not read (a second copy) leaves epoch 2 whole
        expected = tree["w"] + (epoch == 2)
        np.testing.assert_array_equal(restored["w"], expected, err_msg=str(rel))
        # our warning (another library's late asyncio report may land in the same capture)
        ours = [r.getMessage() for r in caplog.records if r.name.startswith("mjx_skills")]
        assert all(len(m) < 500 and "tensorstore_spec" not in m for m in ours), (rel, ours)
        assert ours or epoch == 2, rel  # a fall back is said


def test_a_checkpoint_newer_than_the_whole_log_is_not_resumed_from(tmp_path, tiny_train):
    """A crash cut epoch 3's log line after its checkpoint was saved: the resume starts from
    epoch 2's checkpoint, so epoch 3 is trained again and logged, not lost."""
    from mjx_skills.config import TrainConfig
    from mjx_skills.training.runner import RunArgs, train_run

    args = RunArgs(train=TrainConfig(**tiny_train, epochs=3, checkpoint_every=1, out=str(tmp_path)))
    run_dir = train_run(args)
    path = run_dir / "metrics.jsonl"
    path.write_bytes(path.read_bytes()[:-20])  # epoch 3's line cut short
    train_run(RunArgs(resume=str(run_dir), extend_to=4))
    assert [r["epoch"] for r in read_metrics(run_dir)] == [1, 2, 3, 4]
