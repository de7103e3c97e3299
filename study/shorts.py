"""Where our data falls short of the thesis, and what the logs and the follow-up
experiments say about why: the report's "shorts" section, computed from the stored cells."""

from __future__ import annotations

from mjx_skills.analysis import stats
from study.claims import above, ci, learns, reaches_one


def _tried(variant: stats.Summary | None, default: stats.Summary, held: bool = False) -> str:
    """What the experiment that tests the explanation showed (empty while it is not run)."""
    if variant is None:
        return ""
    what = (
        "With half of the training episodes starting with the cube closed in the fingers "
        "(`take_out_held`: the HER paper's trick; evaluation as before)"
        if held
        else "With the thesis's single goal (`pas_single_goal`: every episode's goal is the mean "
        "of pick_move's goal distribution, trained and evaluated on it)"
    )
    if above(variant, default, "last"):
        verdict = f"it learns: last 5 epochs {ci(variant.last)}" + (
            f", 0.9 first reached (5-epoch rolling mean) at epoch {variant.reach_90}"
            if variant.reach_90
            else ""
        )
        return f" {what}, {verdict}; that is what was missing."
    return f" {what}, it stays at {ci(variant.last)}: that alone does not explain it."


def shorts(r) -> list[str]:
    """The shorts the thesis does not share, with what the logs say about why, from
    `results.Results` r."""
    out = []
    cell, d = r.find("fig6_3", "take_out", "ddpg_her")
    if d is not None and not learns(d):
        won = r.mean_of("fig6_3", "take_out", "ddpg_her", "train_success")
        episodes = max(m["episodes"] for m in r.metrics[cell.name]) * d.seeds
        out.append(
            f"- **DDPG+HER on take_out** (the thesis: it learns, slower than the others): last 5 "
            f"epochs {ci(d.last)}. Of its {episodes:,} training episodes (all seeds), "
            f"{won:.1%} ended at the goal, so it learns only from hindsight goals: wherever the "
            "cube happened to end. Our goal lies above the container, 10-22 cm over the table "
            "(`mjx_skills/envs/tasks.py`, TakeOut; the thesis says only 'on the top of the container'), "
            "so reaching it takes a grasp and a lift that random exploration did not find in "
            f"100 epochs.{_tried(r.get('take_out_held', 'take_out', 'ddpg_her'), d, held=True)}"
            f"{_held_note(r)}"
        )
    for task in ("pick_move", "put_in_container"):
        p, m = r.get("fig6_3", task, "pas"), r.get("fig6_3", task, "mpas")
        if p is None or m is None or learns(p, r.get("fig6_3", task, "ddpg_her")):
            continue
        won = r.mean_of("fig6_3", task, "pas", "train_success")
        ok = r.mean_of("fig6_3", task, "pas", "explore_skill_success")
        out.append(
            f"- **PAS on {task}** (the thesis: it learns): last 5 epochs {ci(p.last)}, MPAS "
            f"{ci(m.last)}. PAS's skills reached the goals it chose {ok:.0%} of the time, but "
            f"only {won:.1%} of its training episodes ended at the task's goal, the only reward "
            "PAS learns from: without hindsight its critic sees almost no success. MPAS, the "
            "same meta-controller with hindsight at the skill level, learns from every "
            f"episode.{_tried(r.get('pas_single_goal', task, 'pas'), p) if task == 'pick_move' else ''}"
        )
    out += _without_grasp(r)
    cell, s = r.find("fig6_5", "container_wall", "ddpg_her_sl")
    flat = r.get("fig6_5", "container_wall", "ddpg_her")
    if s is not None and not learns(s, flat):
        scores = stats.scores_from_rows(r.metrics[cell.name])
        per_seed = scores[:, -stats.LAST :].mean(axis=1)
        late, before = scores[:, -10:].mean(), scores[:, -20:-10].mean()
        versus = "above" if flat and above(s, flat, "last") else "not clearly above"
        out.append(
            f"- **DDPG+HER+SL on container_wall** (the thesis: it learns where DDPG+HER fails): "
            f"last 5 epochs {ci(s.last)}, {versus} DDPG+HER's, but short of 'learns' by our rule: "
            f"{int((per_seed >= 0.25).sum())} of {len(per_seed)} seeds hold 0.25 or more over "
            f"their last 5 epochs (seeds: {', '.join(f'{x:.2f}' for x in per_seed)}), and the "
            f"mean rose from {before:.2f} over the 10 epochs before to {late:.2f} over the last 10: "
            "still learning when the budget ends. The coarse models were learned without the "
            "wall, so the search plans through it until the stall memory prunes those paths "
            "([methods](methods.md)); the learner improves late, from its own relabelled episodes, "
            "after eps has decayed."
        )
    out += _not_optimal(r)
    return out or ["The shorts are stated once their cells are in."]


def _not_optimal(r) -> list[str]:
    """DDPG+HER+SL learns a task but its last-5 interval excludes 1.0 (C8)."""
    out = []
    for task in ("pick_move", "put_in_container"):
        cell, s = r.find("fig6_3", task, "ddpg_her_sl")
        if s is None or reaches_one(s) or not learns(s, r.get("fig6_3", task, "ddpg_her")):
            continue
        scores = stats.scores_from_rows(r.metrics[cell.name])[:, -stats.LAST :]
        out.append(
            f"- **DDPG+HER+SL's final success on {task}** (the thesis: it converges to the "
            f"optimal policy, 100 %): last 5 epochs {ci(s.last)}, an interval that excludes "
            f"1.0; {int((scores == 1.0).sum())} of its {scores.size} last evaluations "
            f"(seeds x epochs, 20 episodes each) solved every episode. It learns the task but "
            "has not converged to the optimal policy in 100 epochs; why not (the learner's "
            "capacity, eps's floor, or episodes the task's start makes hard) is not "
            "investigated yet."
        )
    return out


def _without_grasp(r) -> list[str]:
    """SL3 (transit, transfer): why it does not learn, from its logs at eps = 1."""
    found = [
        (task, *r.find("fig6_4", task, "ddpg_her_sl", "SL3"))
        for task in ("pick_move", "put_in_container")
    ]
    found = [
        (t, c, s)
        for t, c, s in found
        if s is not None and not learns(s, r.get("fig6_3", t, "ddpg_her"))
    ]
    if not found:
        return []
    parts = []
    for task, cell, s in found:
        first = [m for m in r.metrics[cell.name] if m["epoch"] == 1]
        pruned = sum(m["explore_all_pruned"] for m in first) / sum(
            m["explore_searches"] for m in first
        )
        won = r.mean_of("fig6_4", task, "ddpg_her_sl", "train_success", "SL3")
        parts.append(
            f"{task} {ci(s.last)} (at eps = 1 every edge was pruned in {pruned:.0%} of "
            f"the searches; {won:.1%} of all training episodes succeeded)"
        )
    return [
        "- **DDPG+HER+SL with SL3 = {transit, transfer}** (the thesis: slower than SL1, but it "
        f"learns): last 5 epochs {'; '.join(parts)}. Transfer starts only with the cube in "
        "hand (its training start; `skills.library.allowed_skills`), and without grasp nothing "
        "puts it there: the search can only send the open gripper about, its classifiers "
        "reject most such edges, and the explorer never shows the learner a cube lifted. The "
        "thesis does not say how its SL3 got the cube into the gripper."
    ]


def _held_note(r) -> str:
    """What the held-start run's own training episodes show (empty while it is not run)."""
    if r.get("take_out_held", "take_out", "ddpg_her") is None:
        return ""
    won = r.mean_of("take_out_held", "take_out", "ddpg_her", "train_success")
    return (
        f" Its training episodes, held starts included, ended at the goal {won:.1%} of the "
        "time: even a cube that starts in the fingers was not carried 10-22 cm up by the "
        "exploring policy. Not tried yet: a goal band that starts lower (the thesis's 'on the "
        "top of the container' may mean just above the rim)."
    )
