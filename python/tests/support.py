"""What the Python tests need from outside the repository, in one place: the rigfit executable
of the same build (RIGFIT_CLI, set by ctest) and the real data of ../shared/data
(RIGFIT_SHARED_DATA_DIR, set by ctest).

A bare local clone without them skips the tests that need them, saying why; under CI
(CI=true, set by .ci/run) a missing executable or data set fails those tests instead, so that
nothing passes unnoticed there. The module itself is imported plainly by every test file: an
extension that fails to import fails the suite, locally too.
"""

import os
import pathlib

import pytest

IN_CI = os.environ.get("CI", "").lower() in ("true", "1")

CLI = os.environ.get("RIGFIT_CLI", "")
DATA = pathlib.Path(os.environ.get("RIGFIT_SHARED_DATA_DIR")
                    or pathlib.Path(__file__).resolve().parents[3] / "shared" / "data")


def skip_or_fail(reason):
    """Skips the calling test (a bare local clone); fails it under CI."""
    if IN_CI:
        pytest.fail(f"{reason} (CI=true: a missing input fails)", pytrace=False)
    pytest.skip(f"{reason} (outside CI: skipped)")


CLI_REASON = "RIGFIT_CLI (the rigfit executable) not set"
HAVE_CLI = bool(CLI) and os.path.exists(CLI)
# Marks a test that runs the executable: skipped without it outside CI; under CI it runs, and
# fails.
need_cli = pytest.mark.skipif(not HAVE_CLI and not IN_CI, reason=f"{CLI_REASON} (outside CI)")


def require_cli():
    """For a fixture that runs the executable: skips or fails (skip_or_fail) without it."""
    if not HAVE_CLI:
        skip_or_fail(CLI_REASON)


def need_data(path):
    """A folder of ../shared/data; skips or fails (skip_or_fail) when it is absent."""
    if not path.is_dir():
        skip_or_fail(f"{path} not found: the real data of ../shared/data (see its README.md)")
    return path

