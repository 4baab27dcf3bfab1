"""The habits of the field (issue 20.4): ruff and mypy, configured in pyproject.toml, are
clean. Both run as the README's test command runs them, from the project's root."""
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _run(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)


def test_ruff_is_clean():
    """pycodestyle, pyflakes, isort, pyupgrade and bugbear rules at line length 100 over
    the whole tree (``[tool.ruff]``)."""
    run = _run("ruff", "check", "--no-cache", ".")
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def test_mypy_is_clean():
    """The results, the public faces and lagrange_core/systems.py type-check
    (``[tool.mypy]``; untyped function bodies are checked too)."""
    run = _run("mypy", "--cache-dir", str(ROOT / ".mypy_cache"), timeout=600)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def test_one_source_for_the_version():
    """The version lives in pyproject.toml only; both packages read it from the
    installed distribution's metadata."""
    import tomllib
    from importlib.metadata import version

    import kapitza
    import lagrange_core

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert kapitza.__version__ == lagrange_core.__version__ == version("kapitza") == declared
    assert declared == "0.2.0"
    for package in ("kapitza", "lagrange_core"):
        assert (ROOT / package / "py.typed").exists()
        for path in (ROOT / package).rglob("*.py"):
            text = path.read_text().replace("__version__ = \"0+unknown\"", "")
            assert "__version__ = \"" not in text, f"a version written in {path}"
