"""The skill library rebuilt from a clean commit, set beside the committed one (issue #44)."""

import json

from study import rebuild


def _write(path, manifest):
    path.write_text(json.dumps(manifest))
    return path


def test_the_committed_rebuild_reproduces_the_library_bit_for_bit():
    """The committed rebuild was made from a clean commit, and the report says what it shows:
    the same figures and the same arrays' digest as the committed library."""
    committed = json.loads(rebuild.COMMITTED.read_text())
    rebuilt = json.loads(rebuild.REBUILD.read_text())
    assert not rebuilt["commit"].endswith("+dirty") and committed["commit"].endswith("+dirty")
    assert rebuild.differences(committed, rebuilt) == []
    text = rebuild.section()[0]
    assert "all 18 figures below are identical" in text
    assert "bit for bit the committed library's" in text


def test_a_changed_figure_digest_or_field_is_reported(tmp_path):
    committed = json.loads(rebuild.COMMITTED.read_text())
    changed = json.loads(json.dumps(committed))
    changed["models"]["grasp"]["model_error_cm"] += 0.5
    changed["digest"] = "0" * 64
    changed["library"] = {**changed["library"], "samples": 123}
    a = _write(tmp_path / "a.json", committed)
    b = _write(tmp_path / "b.json", changed)
    assert rebuild.differences(committed, changed) == [
        (
            "grasp",
            "model cm",
            committed["models"]["grasp"]["model_error_cm"],
            changed["models"]["grasp"]["model_error_cm"],
        )
    ]
    text = rebuild.section(a, b)[0]
    assert "1 of 18 figures differ" in text and "its arrays differ" in text
    assert "`library.samples`: 10000 -> 123" in text
    rows = [line for line in rebuild.section(a, b) if line.startswith("| grasp | model cm")]
    assert len(rows) == 1 and rows[0].split("|")[3] != rows[0].split("|")[4]
    assert rebuild.section(tmp_path / "none.json", b) == [
        "No rebuild of the skill library is committed yet."
    ]
