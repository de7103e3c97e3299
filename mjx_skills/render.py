"""Video of a trained run's final policy (one trained seed) on fresh evaluation episodes.

python -m mjx_skills.render RUN_DIR [--episodes 1] [--out RUN_DIR/render.gif] [--seed 10000]
    [--run-seed 0] [--width 480 --height 360] [--camera NAME] [--overwrite] [--solved]

The episodes run in the JAX env on the native backend (`rollout.run_episodes` with the
method's deterministic evaluation behaviour, as `python -m mjx_skills.evaluate`); each state's
joint positions are then set on one MjData and drawn offscreen by `mujoco.Renderer`: one
frame per env step (0.15 s of simulated time), each episode's start state included, with
the desired goal marked by a translucent green sphere (each cube's on two-cube tasks).
`--solved` draws only the episodes that end solved, and says how many of those run did.

OpenGL: MuJoCo picks its GL backend from MUJOCO_GL when it is first imported. Without a
display, use MUJOCO_GL=egl (Debian packages libegl1, libegl-mesa0 and libgl1-mesa-dri: a
GPU's driver or Mesa's software renderer) or MUJOCO_GL=osmesa (libosmesa6; software only).
Before it imports mujoco this command tries, each in a short subprocess, the MUJOCO_GL you
set and then egl, osmesa and glfw (only these when unset), and uses the first that draws,
with a warning when it is not the one you set (or, unset, not egl); when none can make a GL
context it says so in one line and exits with status 1.

Output: .gif (Pillow; identical consecutive frames, e.g. an arm at rest, are stored once with
their durations added, so the playing time stays exact) or .mp4 (needs an ffmpeg executable,
on PATH or from the imageio-ffmpeg package). An existing file is kept unless --overwrite.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.cli_args import positive_int, run_parser
from mjx_skills.core import compile_cache, plugins, rollout
from mjx_skills.core.precision import use_float32

# Nothing imported above imports mujoco: it picks its GL backend on its first import, and
# `main` sets MUJOCO_GL before that. Modules that import mujoco are imported in functions.

DEFAULT_VIEW = {"lookat": (0.55, -0.2, 0.05), "distance": 1.8, "azimuth": 130.0, "elevation": -22.0}
"""Free camera on the table, the cube and the arm (the scenes define no cameras)."""


def ffmpeg_executable() -> str | None:
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):  # not installed, or its binary is missing
        return shutil.which("ffmpeg")


def output_path(run_dir: Path, out: Path | None, overwrite: bool) -> Path:
    """The video's path, checked before any work: SystemExit with one line if unusable."""
    out = out or run_dir / "render.gif"
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise SystemExit(f"error: {out}: the video must be a .gif or an .mp4")
    if out.exists() and not overwrite:
        raise SystemExit(f"error: {out} exists; pass --overwrite or choose another --out")
    if out.suffix.lower() == ".mp4" and ffmpeg_executable() is None:
        raise SystemExit(
            "error: .mp4 needs ffmpeg (install ffmpeg, or pip install imageio-ffmpeg); "
            "or write a GIF: --out FILE.gif"
        )
    return out


GL_BACKENDS = ("egl", "osmesa", "glfw")
"""MuJoCo's GL backends for offscreen drawing on Linux, in the order they are tried."""

GL_FIX = (
    "use MUJOCO_GL=egl (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri) or "
    "MUJOCO_GL=osmesa (Debian: libosmesa6)"
)
_GL_PROBE = """
import warnings; warnings.simplefilter("ignore")
import mujoco
mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8).render()
"""


def probe_gl(backend: str, timeout: float = 60.0) -> str | None:
    """None if a fresh Python with MUJOCO_GL=`backend` draws offscreen, else why, in one line
    (a subprocess: MuJoCo fixes its backend at its first import, which cannot be undone)."""
    env = {**os.environ, "MUJOCO_GL": backend}
    command = [sys.executable, "-c", _GL_PROBE]
    try:
        done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f"no frame within {timeout:g} s"
    except OSError as err:
        return str(err)
    if done.returncode == 0:
        return None
    return (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]


def choose_gl() -> str:
    """Set MUJOCO_GL to the first backend that draws (the one set first, then `GL_BACKENDS`)
    and return it, warning when it is not the one set (unset: not the first). RuntimeError
    in one line, MUJOCO_GL as it was, when none draws. Call it before mujoco is imported."""
    wanted = os.environ.get("MUJOCO_GL", "")
    order = [wanted] * bool(wanted) + [b for b in GL_BACKENDS if b != wanted.strip().lower()]
    failed = []
    for backend in order:
        why = probe_gl(backend)
        if why is None:
            break
        failed.append(f"MUJOCO_GL={backend!r}: {why}")
    else:
        raise RuntimeError(
            f"no OpenGL context for offscreen rendering ({'; '.join(failed)}); " + GL_FIX
        )
    if failed:
        warnings.warn(f"{'; '.join(failed)}; drawing with MUJOCO_GL={backend!r}", stacklevel=2)
    os.environ["MUJOCO_GL"] = backend
    return backend


def gl_error() -> str | None:
    """None if an offscreen OpenGL context can be made, else why not, in one line."""
    try:
        # glfw reports its failures as Python warnings too; the one line below says it all.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import mujoco

            mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8).close()
    except Exception as err:  # noqa: BLE001 - each GL backend fails in its own way
        why = (str(err).strip().splitlines() or [type(err).__name__])[0]
        return (
            f"no OpenGL context for offscreen rendering (MUJOCO_GL="
            f"{os.environ.get('MUJOCO_GL', '')!r}: {why}); {GL_FIX}"
        )
    return None


def record_episodes(
    run: Any, key: jax.Array, episodes: int, run_seed: int = 0
) -> tuple[np.ndarray, ...]:
    """Trained seed `run_seed`'s evaluation episodes of a `mjx_skills.evaluate.TrainedRun` ->
    joint positions (n, T + 1, nq), grip positions (n, T + 1, 3), final success (n,) and
    desired goals (n, T + 1, goal_dim)."""
    qpos_of = run.env.backend.qpos

    def fn(agent, aux, key):
        behaviour = run.learner.evaluate(agent, aux)

        # The scan returns observations, not states: the behaviour records each state's
        # joints on the side (behaviour records are stacked over steps by the scan).
        def step(pstate, k, state):
            pstate, action, record = behaviour.step(pstate, k, state)
            return pstate, action, {**record, "render_qpos": qpos_of(state.physics)}

        recording = rollout.Behaviour(init=behaviour.init, step=step)
        recorded, final, records = rollout.run_episodes(run.env, recording, key, episodes)
        qpos = jnp.concatenate([records["render_qpos"], qpos_of(final.physics)[:, None]], 1)
        goals = jnp.concatenate([recorded.g, final.desired_goal[:, None]], 1)
        grip = recorded.obs[..., run.env.layout["grip"]]
        return qpos, grip, final.metrics["success"], goals

    n_seeds = jax.tree.leaves(run.agents)[0].shape[0]
    if not 0 <= run_seed < n_seeds:
        raise ValueError(f"--run-seed {run_seed}: the run trained seeds 0..{n_seeds - 1}")
    from mjx_skills.evaluate import seed_agent

    agent = seed_agent(run, run_seed)
    return tuple(np.asarray(x) for x in jax.jit(fn)(agent, run.aux, key))


def solved_only(qpos, grip, success, goals=None) -> tuple[np.ndarray, ...]:
    """`record_episodes`' qpos (n, T + 1, nq), grip (n, T + 1, 3) and goals (n, T + 1, g),
    if given, of the episodes whose success (n,) is set. ValueError when none is."""
    solved = np.asarray(success) > 0
    if not solved.any():
        raise ValueError(
            f"none of the {len(solved)} episode(s) was solved; nothing to draw "
            "(try more --episodes)"
        )
    kept = (np.asarray(qpos)[solved], np.asarray(grip)[solved])
    return kept if goals is None else (*kept, np.asarray(goals)[solved])


GOAL_RGBA = (0.1, 0.9, 0.2, 0.6)
"""The goal markers' colour: translucent green (each cube's goal on a several-cube task)."""
GOAL_RADIUS = 0.02
"""The goal markers' radius in m (gymnasium-robotics draws its target as a 2 cm sphere)."""


def mark_goals(scene: Any, goal: np.ndarray) -> None:
    """Add a sphere to a `mujoco.MjvScene` at each 3-D point of `goal` (goal_dim,): the
    cube's goal, each cube's on a several-cube task; nothing where goal_dim is not a
    multiple of 3 or the scene is full."""
    import mujoco

    if goal.size % 3:
        return
    for point in goal.reshape(-1, 3):
        if scene.ngeom >= scene.maxgeom:
            return
        mujoco.mjv_initGeom(
            scene.geoms[scene.ngeom],
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=np.array([GOAL_RADIUS, 0.0, 0.0]),
            pos=np.asarray(point, np.float64),
            mat=np.eye(3).ravel(),
            rgba=np.array(GOAL_RGBA, np.float32),
        )
        scene.ngeom += 1


def draw_frames(
    model: Any,
    qpos: np.ndarray,
    grip: np.ndarray,
    width: int,
    height: int,
    camera: str | None,
    default_view: dict = DEFAULT_VIEW,
    goals: np.ndarray | None = None,
) -> np.ndarray:
    """(frames, height, width, 3) uint8: each qpos set on one MjData and drawn (from
    `default_view`, a free camera, unless `camera` names one of the model's), with the
    frame's desired goal (`goals`, (..., goal_dim) as qpos) marked (`mark_goals`)."""
    import mujoco

    if camera is not None and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera) < 0:
        names = [model.camera(i).name for i in range(model.ncam)]
        raise ValueError(f"no camera {camera!r} in the model (cameras: {names or 'none'})")
    view = camera
    if view is None:
        view = mujoco.MjvCamera()
        view.lookat[:] = default_view["lookat"]
        view.distance = default_view["distance"]
        view.azimuth, view.elevation = default_view["azimuth"], default_view["elevation"]
    # The offscreen buffer bounds the image size (640 x 480 by default); this model is ours.
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    data = mujoco.MjData(model)
    frames = []
    with mujoco.Renderer(model, height, width) as renderer:
        steps = len(qpos.reshape(-1, model.nq))
        goal_rows = [None] * steps if goals is None else goals.reshape(steps, -1)
        rows = zip(qpos.reshape(-1, model.nq), grip.reshape(-1, 3), goal_rows, strict=True)
        for q, g, goal in rows:
            data.qpos[:] = q
            # The weld's target (a faint red marker) follows the grip, as during the step.
            data.mocap_pos[0] = g
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera=view)
            if goal is not None:
                mark_goals(renderer.scene, goal)
            frames.append(renderer.render())
    return np.stack(frames)


def write_video(path: Path, frames: np.ndarray, frame_s: float) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        from PIL import Image  # Pillow comes with matplotlib, a dependency

        images = [Image.fromarray(f) for f in frames]
        # GIF frame times are whole centiseconds.
        frame_ms = 10 * max(1, round(100 * frame_s))
        images[0].save(path, save_all=True, append_images=images[1:], duration=frame_ms, loop=0)
        return
    height, width = frames.shape[1:3]
    size, rate = f"{width}x{height}", f"{1 / frame_s:.6f}"
    raw = ["-f", "rawvideo", "-pix_fmt", "rgb24", "-s", size, "-r", rate, "-i", "-"]
    # yuv420p (what players expect) needs even sides.
    encoded = ["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", str(path)]
    command = [ffmpeg_executable() or "ffmpeg", "-loglevel", "error", "-y", *raw, *encoded]
    done = subprocess.run(command, input=frames.tobytes(), capture_output=True)
    if done.returncode != 0:
        why = (done.stderr.decode(errors="replace").strip().splitlines() or ["?"])[-1]
        raise SystemExit(f"error: ffmpeg could not write {path}: {why}")


def parse_args(argv: list[str] | None):
    parser = run_parser("python -m mjx_skills.render", __doc__, episodes=1)
    parser.add_argument("--out", type=Path, help="FILE.gif or FILE.mp4 (RUN_DIR/render.gif)")
    parser.add_argument("--run-seed", type=int, default=0, help="which trained seed acts")
    parser.add_argument("--width", type=positive_int, default=480)
    parser.add_argument("--height", type=positive_int, default=360)
    parser.add_argument("--camera", help="a camera of the model (default: a free view)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    parser.add_argument(
        "--solved",
        action="store_true",
        help="draw only the episodes the policy solves (of the --episodes run; "
        "the line printed says how many)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    # A user's module imports mujoco: loaded once MUJOCO_GL is chosen (`choose_gl`).
    args = parse_args(plugins.take_imports(sys.argv[1:] if argv is None else argv, False))
    out = output_path(args.run_dir, args.out, args.overwrite)
    compile_cache.enable()
    use_float32()
    try:
        if "mujoco" not in sys.modules:  # else its backend is fixed: gl_error says if it draws
            choose_gl()  # before mujoco's first import, in gl_error
    except RuntimeError as err:
        raise SystemExit(f"error: {err}") from None
    problem = gl_error()
    if problem:
        raise SystemExit(f"error: {problem}")
    plugins.load_named()
    from mjx_skills import evaluate as evaluation

    try:
        run = evaluation.load_trained(args.run_dir, physics="native")
        qpos, grip, success, goals = record_episodes(
            run, jax.random.PRNGKey(args.seed), args.episodes, args.run_seed
        )
        if args.solved:
            qpos, grip, goals = solved_only(qpos, grip, success, goals)
        view = getattr(run.env, "render_view", DEFAULT_VIEW)  # Fetch: gymnasium-robotics'
        frames = draw_frames(
            run.env.model, qpos, grip, args.width, args.height, args.camera, view, goals
        )
    except (FileNotFoundError, ValueError, NotImplementedError) as err:
        # Not a run, no checkpoint, an unknown camera, a missing skill library.
        raise SystemExit(f"error: {err}") from None
    frame_s = getattr(run.env, "dt", 0.0) or run.env.model.opt.timestep * run.env.config.n_substeps
    write_video(out, frames, frame_s)
    drawn = f"the {len(qpos)} solved of {args.episodes}" if args.solved else args.episodes
    print(
        f"{out}: {drawn} episode(s) of seed {args.run_seed} at epoch {run.epoch}, {len(frames)} "
        f"frames of {args.width}x{args.height}, {1 / frame_s:.2f} per second; "
        f"success {[int(s) for s in success]}"
    )


if __name__ == "__main__":
    main()
