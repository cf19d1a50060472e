# SPDX-License-Identifier: Apache-2.0
"""Fixtures for the clvox Python tests, and the "N passed, N failed" line that
tests/run_tests.sh adds to the suite's total."""
import os
import signal
import subprocess

import pytest

# A process started in the background by a non-interactive shell (`sh -c
# "... &"`) inherits SIGINT ignored, and Python then installs no
# KeyboardInterrupt handler: the Ctrl-C tests would see their run finish.
# Ctrl-C behaves as in a terminal whatever started the tests.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MESHES = os.path.join(REPO, "data", "meshes")
DEFAULT = os.path.join(REPO, "tests", "data", "default.obj")


@pytest.fixture(scope="session")
def ctx():
    import clvox
    return clvox.Context()


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("CLVOX_BIN") or os.path.join(REPO, "build", "release", "clvox")
    if not os.access(path, os.X_OK):
        pytest.fail(f"no clvox binary at {path} (run make)")

    def run(*args):
        p = subprocess.run([path, "-q", "--no-progress", *map(str, args)], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        return p
    return run


@pytest.fixture
def tmp(tmp_path):
    return tmp_path


def mesh_path(name):
    p = os.path.join(MESHES, name)
    if not os.path.exists(p):
        pytest.skip(f"{p} missing (scripts/fetch_meshes.sh)")
    return p


def pytest_terminal_summary(terminalreporter):
    stats = terminalreporter.stats
    passed = len(stats.get("passed", []))
    failed = len(stats.get("failed", [])) + len(stats.get("error", []))
    terminalreporter.write_line(f"{passed} passed, {failed} failed")
