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
