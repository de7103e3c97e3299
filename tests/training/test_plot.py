"""`python -m mjx_skills.plot`: a run's learning curve from its metrics.jsonl."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjx_skills import plot


def _run(tmp_path, name="run", epochs=3, seeds=2, extra=False):
    run = tmp_path / name
    run.mkdir()
    rows = [
        {"epoch": e, "seed": s, "env_steps": 800 * e, "eval_success": 0.1 * e + 0.05 * s}
        for e in range(1, epochs + 1)
        for s in range(seeds)
    ]
    if extra:  # a run mid-epoch: seed 0 has logged an epoch seed 1 has not
        rows.append(
            {"epoch": epochs + 1, "seed": 0, "env_steps": 800 * (epochs + 1), "eval_success": 1.0}
        )
    (run / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return run


def test_a_runs_curve_is_read_per_seed_over_env_steps_and_drawn(tmp_path):
    run = _run(tmp_path, extra=True)
    steps, scores = plot.curves(run)
    np.testing.assert_array_equal(steps, [800, 1600, 2400])  # the epochs every seed has
    np.testing.assert_allclose(scores, [[0.1, 0.2, 0.3], [0.15, 0.25, 0.35]])
    assert plot.main([str(run)]) == 0
    png = run / "curve.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    other = _run(tmp_path, "other", seeds=1)
    out = tmp_path / "both.png"
    assert plot.main([str(run), str(other), "--out", str(out), "--x", "epoch"]) == 0
    assert out.stat().st_size > 0


def test_bad_input_names_what_is_wrong(tmp_path, capsys):
    run = _run(tmp_path)
    with pytest.raises(ValueError, match="unknown metric 'nope'; logged: env_steps, epoch"):
        plot.curves(run, "nope")
    assert plot.main([str(tmp_path / "missing")]) == 2
    assert "no metrics.jsonl" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # several runs and no --out
        plot.main([str(run), str(run)])
