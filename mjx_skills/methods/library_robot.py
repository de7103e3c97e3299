"""Whether a method's skill library is of the task's robot (`check_robot`), read from
the library's manifest before a run writes anything."""

from __future__ import annotations

from typing import Any


def check_robot(
    method: str, group: str, chosen: Any, task: str, presets: set[str], flat: list[str]
) -> None:
    """ValueError if the library that `method`'s option group `group` (`chosen`, its value)
    names is built for another robot than `task`'s (`methods.check_library_robot`, which
    passes the preset names and the methods without a library, `flat`, for the message)."""
    from mjx_skills.core.files import read_json
    from mjx_skills.core.paths import in_checkout
    from mjx_skills.envs.registry import robot_of
    from mjx_skills.skills.library import default_dir, library_robot
    from mjx_skills.skills.registry import (
        libraries_of,
        library_robot_name,
        library_skills,
        robots_with_skills,
        skills_of,
    )

    robot = robot_of(task)
    skills = library_skills(chosen.library)  # ValueError naming the registered libraries
    directory = in_checkout(chosen.library_dir)
    manifest = directory / "manifest.json"
    named_for = library_robot_name(chosen.library)
    built = read_json(manifest) if manifest.exists() else {}
    built_for = library_robot(built) if built else named_for  # what would be built there
    if built_for == robot and named_for != robot:
        raise ValueError(
            f"--{group}.library {chosen.library} names {named_for.capitalize()} skills; "
            f"{task} is a {robot.capitalize()} task: pass --{group}.library "
            f"{' or '.join(libraries_of(robot))}"
        )
    if built_for == robot:  # the right robot: does it hold the skills the name needs?
        models = built.get("models")  # a manifest without them (a fake) says nothing
        lacking = [n for n in skills if n not in models] if models is not None else []
        if lacking:
            raise ValueError(
                f"--{group}.library {chosen.library} needs the skills {', '.join(skills)}; the "
                f"library at {directory} (--{group}.library-dir) was built without "
                f"{', '.join(lacking)}: build one with them (`python -m mjx_skills.build_library "
                f"--import YOUR_MODULE --out DIR`) and pass --{group}.library-dir DIR"
            )
        return
    flag = f"--{group}.library-dir"
    state = "is built" if manifest.exists() else "would be built (none there yet)"
    said = f"the skill library {state} for the {built_for.capitalize()} robot ({directory})"
    if robot in robots_with_skills():
        raise ValueError(
            f"{said}; {task} is a {robot.capitalize()} task, which {method} cannot run with "
            f"it: pass --{group}.library {' or '.join(libraries_of(robot))} (the "
            f"{robot.capitalize()} skills) and {flag} {default_dir(robot)}, which `python -m "
            f"mjx_skills.build_library --robot {robot} --library {libraries_of(robot)[0]}` "
            f"builds (`make skills ROBOT={robot}`)"
            + (f"; `--preset {robot}` sets both" if robot in presets else "")
        )
    raise ValueError(
        f"{said}; {task} is a {robot.capitalize()} task, which {method} cannot run: no "
        f"skills of the {robot.capitalize()} robot are registered (`python -m "
        f"mjx_skills.build_library` trains the skill envs {', '.join(skills_of(built_for))}, which are "
        f"{built_for.capitalize()}'s; docs/extending.md says how to register skills): train "
        f"{task} with {', '.join(flat)}"
    )
