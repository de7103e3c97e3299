"""Optional machinery that fails degrades with a warning and never stops a run or a command:
the compilation cache, and the render command's OpenGL backend."""

import os
import warnings
from pathlib import Path

import jax
import pytest

from mjx_skills import render
from mjx_skills.core import compile_cache

SETTINGS = (
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


def settings() -> dict:
    return {name: getattr(jax.config, name) for name in SETTINGS}


@pytest.fixture
def jax_settings():
    """JAX's cache settings before the test, restored after it."""
    before, update = settings(), jax.config.update
    yield before
    for name, value in before.items():
        update(name, value)  # the real one, whatever a test monkeypatched


def unusable_dirs(tmp: Path) -> dict[str, Path]:
    (tmp / "a_file").write_text("not a directory")
    dirs = {"an existing file": tmp / "a_file", "under a file": tmp / "a_file" / "jax"}
    if Path("/proc/self").is_dir():  # Linux: nobody, not even root, creates files in /proc
        dirs |= {"unwritable": Path("/proc"), "uncreatable": Path("/proc/mjx_skills/jax")}
    return dirs


@pytest.mark.parametrize("case", ["an existing file", "under a file", "unwritable", "uncreatable"])
def test_an_unusable_cache_directory_warns_once_and_the_run_goes_on(
    case, tmp_path, monkeypatch, jax_settings
):
    """An existing file as MJX_SKILLS_CACHE_DIR raised FileExistsError and stopped the run."""
    dirs = unusable_dirs(tmp_path)
    if case not in dirs:
        pytest.skip("no /proc here")
    monkeypatch.setenv(compile_cache.ENV_VAR, str(dirs[case]))
    monkeypatch.setattr(compile_cache, "_warned", False)
    with pytest.warns(UserWarning, match=f"no compilation cache: {dirs[case]}: cannot") as said:
        assert compile_cache.enable() is None
    assert len(said) == 1 and compile_cache.ENV_VAR in str(said[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per process: a second call is silent
        assert compile_cache.enable() is None
    assert settings() == jax_settings


def test_settings_jax_refuses_warn_and_leave_the_settings_as_they_were(
    tmp_path, monkeypatch, jax_settings
):
    update = jax.config.update

    def refuse_sizes(name, value):
        if name == "jax_persistent_cache_min_entry_size_bytes":
            raise AttributeError(f"Unrecognized config option: {name}")
        update(name, value)

    monkeypatch.setenv(compile_cache.ENV_VAR, str(tmp_path / "cache"))
    monkeypatch.setattr(compile_cache, "_warned", False)
    monkeypatch.setattr(jax.config, "update", refuse_sizes)
    with pytest.warns(UserWarning, match="JAX refused its settings .*Unrecognized config"):
        assert compile_cache.enable() is None
    assert settings() == jax_settings  # the directory set before the refusal is undone


# ---------------------------------------------------------------- OpenGL backends
def fake_probes(monkeypatch, working: set[str]) -> list[str]:
    tried = []

    def probe(backend, timeout=60.0):
        tried.append(backend)
        return None if backend in working else f"{backend} cannot draw here"

    monkeypatch.setattr(render, "probe_gl", probe)
    return tried


@pytest.mark.parametrize(
    ("wanted", "working", "chosen", "tried"),
    [
        (None, {"egl", "osmesa"}, "egl", ["egl"]),
        (None, {"osmesa"}, "osmesa", ["egl", "osmesa"]),
        (None, {"glfw"}, "glfw", ["egl", "osmesa", "glfw"]),
        ("osmesa", {"egl", "osmesa"}, "osmesa", ["osmesa"]),
        ("osmesa", {"egl"}, "egl", ["osmesa", "egl"]),
        ("bogus", {"glfw"}, "glfw", ["bogus", "egl", "osmesa", "glfw"]),
    ],
)
def test_the_first_gl_backend_that_draws_is_chosen(monkeypatch, wanted, working, chosen, tried):
    """The command set MUJOCO_GL=egl when unset and stopped when that (or the one set) failed."""
    if wanted is None:
        monkeypatch.delenv("MUJOCO_GL", raising=False)
    else:
        monkeypatch.setenv("MUJOCO_GL", wanted)
    probed = fake_probes(monkeypatch, working)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        assert render.choose_gl() == chosen
    assert probed == tried and os.environ["MUJOCO_GL"] == chosen
    if len(tried) == 1:
        assert not said
    else:  # which failed, and why, and which one draws
        assert len(said) == 1
        message = str(said[0].message)
        assert f"{tried[0]} cannot draw here" in message and f"MUJOCO_GL={chosen!r}" in message


def test_no_gl_backend_is_one_line_naming_each(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    fake_probes(monkeypatch, set())
    with pytest.raises(RuntimeError) as failed:
        render.choose_gl()
    text = str(failed.value)
    assert "\n" not in text and text.startswith("no OpenGL context")
    assert all(f"{b} cannot draw here" in text for b in render.GL_BACKENDS)
    assert os.environ["MUJOCO_GL"] == "osmesa"


def test_a_bogus_mujoco_gl_falls_back_to_a_backend_that_draws(monkeypatch):
    """The probes themselves, in subprocesses: a bogus MUJOCO_GL cannot draw, and the
    backend chosen instead does (skipped where none does)."""
    assert "invalid value for environment variable MUJOCO_GL" in render.probe_gl("bogus")
    if all(render.probe_gl(b) for b in render.GL_BACKENDS):
        pytest.skip("no OpenGL backend draws here")
    monkeypatch.setenv("MUJOCO_GL", "bogus")
    with pytest.warns(UserWarning, match="MUJOCO_GL='bogus'.*drawing with"):
        chosen = render.choose_gl()
    assert chosen in render.GL_BACKENDS and render.probe_gl(chosen) is None
