from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
MESHES = SHARED / "meshes"


@pytest.fixture(scope="session")
def meshes() -> Path:
    if not MESHES.is_dir():
        pytest.fail(f"test meshes not found at {MESHES}: ../shared must sit beside the repo")
    return MESHES
