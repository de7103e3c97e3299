import importlib.metadata

import jax

import mjx_skills
from mjx_skills import compile_cache


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

    code = "import jax, mjx_skills.train; print(jax.config.jax_compilation_cache_dir)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "None"


def test_the_speed_section_is_what_the_committed_results_give():
    """Every figure of docs/benchmarks.md's "Speed" section is computed from committed
    benchmark results by benchmarks/speed_report.py (run it with --write after a benchmark)."""
    import runpy
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    report = runpy.run_path(str(root / "benchmarks" / "speed_report.py"))
    readme = (root / "docs" / "benchmarks.md").read_text()
    start = readme.index(report["BEGIN"])
    end = readme.index(report["END"]) + len(report["END"])
    assert readme[start:end] == report["section"](), "run python benchmarks/speed_report.py --write"
