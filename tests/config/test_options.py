"""Every option of every method is read by that method, or refused when set (`Method.unread`):
an option that changes nothing is an error, never a silent no-op."""

from __future__ import annotations

import dataclasses

import jax
import pytest

from mjx_skills import methods
from mjx_skills.config import TrainConfig
from mjx_skills.envs import make
from mjx_skills.skills.library import DEFAULT_DIR
from mjx_skills.training.epoch import init_carry, make_train_epoch, over_seeds
from tests.fakes import tiny_train

TINY = TrainConfig(
    **tiny_train(task="pick_move", cycles=1, updates_per_cycle=2, replay_capacity=500)
)


def _tracked(option, seen: set[str]):
    """`option` as an instance of a subclass that records which of its fields are read."""
    names = {f.name for f in dataclasses.fields(option)}

    class Tracked(type(option)):
        def __getattribute__(self, name):
            if name in names:
                seen.add(name)
            return object.__getattribute__(self, name)

    Tracked.__name__ = type(option).__name__
    out = Tracked(**{n: getattr(option, n) for n in names})
    seen.clear()  # construction checks every field
    return out


@pytest.mark.skipif(not (DEFAULT_DIR / "manifest.json").exists(), reason="no built library")
@pytest.mark.parametrize("method", sorted(methods.METHODS))
def test_every_option_of_a_method_is_read_or_refused(method):
    """The method's library is loaded, its learner built and one epoch traced (not run) with
    option groups that record their reads; each field never read must be declared unread,
    so that setting it is refused (`methods.check_read`), and each declared one really is
    unread."""
    spec = methods.get(method)
    seen = {group: set() for group in spec.options}
    options = {group: _tracked(opt, seen[group]) for group, opt in spec.options.items()}
    env = make(TINY.task)
    aux = spec.load_aux(options)
    learner = spec.make_learner(env, TINY, **options)
    epoch = over_seeds(make_train_epoch(learner, env, TINY, env), in_axes=(0, None))
    init = jax.vmap(lambda k: init_carry(learner, env, TINY, k, aux))
    carry = jax.eval_shape(init, jax.random.split(jax.random.PRNGKey(0), 1))
    jax.eval_shape(epoch, carry, aux)
    unread = {
        f"{group}.{f.name}"
        for group, opt in spec.options.items()
        for f in dataclasses.fields(opt)
        if f.name not in seen[group]
    }
    declared = {path for path in spec.unread_now(spec.options) if not path.startswith("train.")}
    assert unread == declared, (
        f"{method}: read by nothing and not refused: {sorted(unread - declared)}; "
        f"declared unread but read: {sorted(declared - unread)}"
    )
