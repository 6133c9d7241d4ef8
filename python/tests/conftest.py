"""Shared fixtures: the repository root and the command-line binary to compare with."""

import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _at_root(monkeypatch):
    """Every test runs in the repository root, where the README's paths resolve."""
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="session")
def cli():
    """The `dexwarp` binary: $DEXWARP_BIN, else target/debug or target/release.

    Under CI a missing binary is a failure, not a skip."""
    given = os.environ.get("DEXWARP_BIN")
    candidates = [pathlib.Path(given)] if given else [
        ROOT / "target" / "debug" / "dexwarp",
        ROOT / "target" / "release" / "dexwarp",
    ]
    for c in candidates:
        if c.is_file():
            return c.resolve()
    message = f"no dexwarp binary at {', '.join(map(str, candidates))}: run `cargo build` first"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)
