"""Shared fixtures: the repository root, a fresh cache per test, the `hdrflow` binary."""

import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture
def cache(tmp_path) -> pathlib.Path:
    return tmp_path / "cache"


@pytest.fixture
def hdrflow_bin() -> str:
    """The command line to compare with: $HDRFLOW_BIN, else the release build of this checkout.
    Missing is a failure, not a skip (.ci/run builds it before running these tests)."""
    candidates = [os.environ.get("HDRFLOW_BIN")]
    if os.environ.get("CARGO_TARGET_DIR"):
        candidates.append(os.path.join(os.environ["CARGO_TARGET_DIR"], "release", "hdrflow"))
    candidates += [str(ROOT / "target" / "release" / "hdrflow"), shutil.which("hdrflow")]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    pytest.fail("no hdrflow binary: build it (cargo build --release) or set HDRFLOW_BIN")
