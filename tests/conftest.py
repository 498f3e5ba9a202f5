"""Shared fixtures: where the recorded scans are."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCANS = REPO.parent / "shared" / "data" / "scans" / "corridor-2023-10-25"


@pytest.fixture(scope="session")
def scans_dir() -> Path:
    """The folder of recorded scans from the paper's robot (skip when absent)."""
    if not SCANS.is_dir():
        pytest.skip(f"recorded scans not found at {SCANS}")
    return SCANS
