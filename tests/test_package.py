import importlib.metadata

import jax
import pytest

import mjx_skills
from mjx_skills.core import compile_cache


def test_pinned_jax():
    # MJX on the CPU is 20x-1000x slower on jax >= 0.7.1: a newer jax must be a deliberate,
    # benchmarked change of pyproject.toml, not an accident of the resolver.
    assert jax.__version__ == "0.6.2"
    assert importlib.metadata.version("jaxlib") == "0.6.2"


def test_package_imports_and_cache_is_on():
    # conftest.py switches the cache on, as the CLI does; importing the package does not.
    assert mjx_skills.__version__
    assert jax.config.jax_compilation_cache_dir == str(compile_cache.cache_dir())


def test_importing_the_package_has_no_side_effects():
    import subprocess
    import sys

    code = "import jax, mjx_skills.training.epoch; print(jax.config.jax_compilation_cache_dir)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "None"


@pytest.mark.parametrize("block", ["speed", "physics", "throughput", "peer"])
def test_the_generated_benchmark_blocks_are_what_the_committed_results_give(block):
    """Every figure of docs/benchmarks.md's "Speed" section, its "Physics" and "Training
    throughput" subsections (the Fetch ratio included) and its "Against Stable-Baselines3"
    section is computed from committed benchmark results by benchmarks/speed_report.py
    (run it with --write after a benchmark)."""
    import runpy
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    report = runpy.run_path(str(root / "benchmarks" / "speed_report.py"))
    blocks = {b[0].split(":")[0].removeprefix("<!-- "): b for b in report["BLOCKS"]}
    begin, end, make = blocks[block]
    readme = (root / "docs" / "benchmarks.md").read_text()
    start = readme.index(begin)
    stop = readme.index(end) + len(end)
    assert readme[start:stop] == make(), "run python benchmarks/speed_report.py --write"


def test_the_suite_time_block_is_what_the_last_committed_row_gives():
    """docs/architecture.md's "The test suite" block comes from the last row of
    benchmarks/results/suite_time.jsonl (benchmarks/suite_time.py --write)."""
    import runpy
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    suite = runpy.run_path(str(root / "benchmarks" / "suite_time.py"))
    page = (root / "docs" / "architecture.md").read_text()
    start, stop = page.index(suite["BEGIN"]), page.index(suite["END"]) + len(suite["END"])
    assert page[start:stop] == "\n".join(suite["block"](suite["rows"]()[-1]))


def test_suite_time_sums_a_junit_report_by_folder(tmp_path):
    import runpy
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    suite = runpy.run_path(str(root / "benchmarks" / "suite_time.py"))
    junit = tmp_path / "junit.xml"
    junit.write_text(
        '<testsuites><testsuite name="pytest">'
        '<testcase classname="tests.envs.test_a" name="x" time="60"/>'
        '<testcase classname="tests.envs.test_a" name="y" time="30"><skipped/></testcase>'
        '<testcase classname="tests.study.test_b" name="z" time="120"><failure/></testcase>'
        '<testcase classname="tests.test_structure" name="w" time="6"/>'
        "</testsuite></testsuites>"
    )
    row = suite["summarize"](junit)
    assert row["total_s"] == 216.0 and (row["passed"], row["failed"], row["skipped"]) == (2, 1, 1)
    assert row["folders_s"] == {"study": 120.0, "envs": 90.0, "(top)": 6.0}
    assert list(row["slowest_files_s"])[0] == "tests/study/test_b.py"
    text = suite["block"]({**row, "commit": "0123456789", "cores": 2, "cache": "cold"})[1]
    assert text.startswith("The whole suite at `0123456` on 2 cores, compilation cache cold:")
    assert "2 passed, 1 failed, 1 skipped in 3.6 min" in text and "envs 1.5" in text


def _cited(text: str):
    """(kind, name) of every file, link, module and command a page cites."""
    import re

    for m in re.finditer(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if not m.group(1).startswith("http"):
            yield "link", m.group(1)
    for m in re.finditer(r"(?<![\w./-])((?:[\w.-]+/)+[\w-]+\.(?:py|toml|md|ipynb|xml))\b", text):
        if not re.search(r"\b[A-Z][A-Z_]+\b", m.group(1)):  # not a placeholder (NAME, RUN_DIR)
            yield "path", m.group(1)
    for m in re.finditer(r"python -m ((?:mjx_skills|study)(?:\.\w+)+)", text):
        yield "command", m.group(1)
    for m in re.finditer(r"\b(?:mjx_skills|study)(?:\.\w+)+", text):
        yield "name", m.group(0)


def _resolves(name: str) -> bool:
    """A dotted name is a module, or an attribute of the longest module it starts with."""
    import importlib
    import importlib.util

    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        module = ".".join(parts[:i])
        try:
            if importlib.util.find_spec(module) is None:
                continue
        except ModuleNotFoundError:
            continue
        obj = importlib.import_module(module)
        for attr in parts[i:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def test_the_docs_cite_only_what_exists():
    """README, docs/, pyproject.toml and the Makefile: every relative link and file path
    exists (paths inside the package may omit `mjx_skills/`), every `mjx_skills.*` and
    `study.*` name imports and every `python -m` command is a runnable module."""
    import importlib.util
    from pathlib import Path

    from mjx_skills.core import plugins

    root = Path(__file__).resolve().parents[1]
    pages = [
        root / "README.md",
        root / "pyproject.toml",
        root / "Makefile",
        *sorted((root / "docs").glob("*.md")),
    ]
    missing = []
    for page in pages:
        for kind, name in _cited(page.read_text()):
            if kind == "link":
                ok = (page.parent / name).exists()
            elif kind == "path":
                ok = (root / name).exists() or (root / "mjx_skills" / name).exists()
            elif kind == "command":
                spec = importlib.util.find_spec(name)
                ok = spec is not None and '__name__ == "__main__"' in Path(spec.origin).read_text()
            else:  # a module or attribute, or the plugins' entry-point group
                ok = _resolves(name.removesuffix(".py")) or name == plugins.GROUP
            if not ok:
                missing.append(f"{page.name}: {kind} {name}")
    assert not missing, missing


def test_the_scripted_section_is_what_the_committed_rates_give():
    """docs/simulation.md's scripted success per env is computed from the committed
    experiments/results/scripted.jsonl (tests/envs/test_solvable.py checks that data against
    today's controllers)."""
    import runpy
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    rates = runpy.run_path(str(root / "experiments" / "diagnostics" / "scripted_rates.py"))
    page = (root / "docs" / "simulation.md").read_text()
    start, end = page.index(rates["BEGIN"]), page.index(rates["END"]) + len(rates["END"])
    assert page[start:end] == rates["section"](), (
        "run python experiments/diagnostics/scripted_rates.py --write"
    )
