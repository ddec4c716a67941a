"""Shared fixtures: the shipped profiles, and a data directory of each test's own (helpers
live in tests/helpers.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.helpers import PROFILES
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile


@pytest.fixture(autouse=True)
def _own_data_dir(tmp_path_factory: pytest.TempPathFactory,
                  monkeypatch: pytest.MonkeyPatch) -> Path:
    """``$TRIMD_DATA_DIR`` in a temporary folder: no test writes session logs or the trim
    history into the user's home."""
    path = tmp_path_factory.mktemp("trimd-data")
    monkeypatch.setenv("TRIMD_DATA_DIR", str(path))
    return path


@pytest.fixture(scope="session")
def sabertooth() -> Profile:
    return load_profile(PROFILES / "sabertooth-dh2.yaml")


@pytest.fixture(scope="session")
def bluerov() -> Profile:
    return load_profile(PROFILES / "bluerov2-heavy.yaml")
