"""The CI script: the README's test command, in an environment of its own."""

import re

from tests.conftest import ROOT

CI = (ROOT / ".ci" / "run").read_text()


def test_ci_runs_the_readmes_test_command_verbatim():
    readme = (ROOT / "README.md").read_text()
    command = 'python -m pip install -e ".[test]" && python -m pytest'
    assert command in readme
    assert command in CI.splitlines()


def test_ci_never_touches_the_users_virtual_environment():
    # The README has users create .venv in the checkout; CI must not wipe or reuse it.
    venv_lines = [line for line in CI.splitlines() if "venv" in line and not line.startswith("#")]
    assert venv_lines
    assert not any(re.search(r"(^|[\s/\"'])\.venv\b", line) for line in venv_lines), venv_lines
    assert 'mktemp -d "${TMPDIR:-/tmp}/' in CI
    assert "trap 'rm -rf" in CI


def test_the_test_command_prints_the_15_slowest_tests():
    # The README's test command and CI's take pytest's options from pyproject.toml alone,
    # so the 15 slowest tests close every run of either (where the suite's time goes).
    import tomllib

    options = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]
    assert "--durations=15" in options["ini_options"]["addopts"].split()
    pytest_lines = [line for line in CI.splitlines() if "python -m pytest" in line]
    assert pytest_lines
    assert not any(re.search(r"\s(-o|--override-ini|--durations|-p)\b", line)
                   for line in pytest_lines)  # fmt: skip


def test_ci_installs_and_builds_the_start_kit_before_the_tests():
    # Its Debian packages (apt-get update first), then one build into the cache folder
    # outside the checkout, both before the README's test command, each saying why not.
    lines = CI.splitlines()
    test_line = lines.index('python -m pip install -e ".[test]" && python -m pytest')
    update = next(i for i, line in enumerate(lines) if "apt-get update" in line)
    build = next(i for i, line in enumerate(lines) if "warehouse_phys.startkit build" in line)
    assert update < build < test_line
    for package in ("cmake", "libboost-log-dev", "pybind11-dev", "python3-dev"):
        assert package in CI
    assert CI.count('echo "ci: ') >= 4  # every way it cannot, said
