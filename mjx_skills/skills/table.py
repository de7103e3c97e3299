"""Table 5.1 of a skill library (thesis ch. 5): each skill's held-out terminal-position error
of memory retrieval, of the coarse model and of the trivial "it ends at its goal" predictor
(cm), its classifier's accuracy and AUC, and its success; the thesis's figures beside ours
(`registry.Skill.thesis_cm`). Computed when the library is built (`evaluate_models`, stored in
its manifest) and written as CSV (`write_table`).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.core.files import write_text_atomic
from mjx_skills.skills import fit, library, registry

TABLE = Path("experiments") / "results" / "table_5_1.csv"
THESIS_CM = {n: s.thesis_cm for n, s in registry.SKILLS.items() if s.thesis_cm}
"""Table 5.1 of the thesis: skill -> (memory retrieval, neural network) terminal error, cm."""


def evaluate_models(lib: library.SkillLibrary, x, s_T, success) -> dict[str, dict[str, float]]:
    """Held-out Table 5.1 figures per skill: terminal-position error (cm) of memory and model
    on successful runs (grip for transit, cube otherwise), classifier accuracy and AUC."""
    obs_dim = s_T.shape[-1]
    out = {}
    for k, (name, env) in enumerate(zip(lib.names, lib.envs, strict=True)):
        obs, goal = jnp.asarray(x[k, :, :obs_dim]), jnp.asarray(x[k, :, obs_dim:])
        ids = jnp.full((obs.shape[0],), k, jnp.int32)
        pos = env.layout["object" if env.goal_is_object else "grip"]
        ok = success[k].astype(bool)
        model = np.asarray(jax.jit(lib.next_state)(ids, obs, goal))
        memory = np.concatenate(
            [
                np.asarray(
                    jax.jit(lib.recall)(ids[i : i + 512], obs[i : i + 512], goal[i : i + 512])
                )
                for i in range(0, obs.shape[0], 512)
            ]
        )
        prob = np.asarray(jax.jit(lib.success_prob)(ids, obs, goal))
        out[name] = {
            "memory_error_cm": _position_error_cm(memory[ok], s_T[k][ok], pos),
            "model_error_cm": _position_error_cm(model[ok], s_T[k][ok], pos),
            # The trivial predictor: a successful run ends at its goal (within the threshold).
            "goal_error_cm": float(
                100 * np.mean(np.linalg.norm(np.asarray(goal)[ok] - s_T[k][ok][:, pos], axis=-1))
            ),
            "classifier_accuracy": float(np.mean((prob > 0.5) == ok)),
            "classifier_auc": fit.auc(prob, ok),
            "held_out": int(len(ok)),
            "held_out_successes": int(ok.sum()),
        }
    return out


def _position_error_cm(predicted: np.ndarray, actual: np.ndarray, pos: slice) -> float:
    return float(100 * np.mean(np.linalg.norm(predicted[:, pos] - actual[:, pos], axis=-1)))


def _thesis_cm(name: str, column: int) -> float | str:
    """Table 5.1 of the thesis (`Skill.thesis_cm`): column 0 memory, 1 model, in cm; '' for
    a skill it has no figure for (or one not registered in this process)."""
    skill = registry.SKILLS.get(name)
    return skill.thesis_cm[column] if skill and skill.thesis_cm else ""


def table_rows(directory: Path) -> list[dict]:
    """Table 5.1 rows (one per skill) from a library's manifest, the thesis's beside ours."""
    manifest = library.read_manifest(directory)
    return [
        {
            "skill": name,
            "memory_error_cm": f"{m['memory_error_cm']:.2f}",
            "model_error_cm": f"{m['model_error_cm']:.2f}",
            "goal_error_cm": f"{m['goal_error_cm']:.2f}" if "goal_error_cm" in m else "",
            "thesis_memory_cm": _thesis_cm(name, 0),
            "thesis_model_cm": _thesis_cm(name, 1),
            "classifier_accuracy": f"{m['classifier_accuracy']:.3f}",
            "classifier_auc": f"{m['classifier_auc']:.3f}",
            "samples": manifest["samples"][name]["total"],
            "anchor": manifest["library"].get("anchor", "start"),
            "skill_success": f"{manifest['skill_success'][name]:.3f}",
        }
        for name, m in manifest["models"].items()
    ]


def write_table(directory: Path | list[Path], path: Path = TABLE) -> Path:
    """Table 5.1 of one library (or several: one block of rows each) as CSV."""
    rows = [
        r
        for d in ([directory] if isinstance(directory, Path) else directory)
        for r in table_rows(d)
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    table = io.StringIO(newline="")
    w = csv.DictWriter(table, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    return write_text_atomic(path, table.getvalue())  # whole or not at all
