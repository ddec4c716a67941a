"""Shared fixtures: the shipped profiles (helpers live in tests/helpers.py)."""

from __future__ import annotations

import pytest

from tests.helpers import PROFILES
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile


@pytest.fixture(scope="session")
def sabertooth() -> Profile:
    return load_profile(PROFILES / "sabertooth-dh2.yaml")


@pytest.fixture(scope="session")
def bluerov() -> Profile:
    return load_profile(PROFILES / "bluerov2-heavy.yaml")
