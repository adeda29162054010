"""What the service's in-process tests share: the app on a fresh data folder, migrated
as `texbake serve` migrates it, through FastAPI's TestClient."""

import pytest
from fastapi.testclient import TestClient


@pytest.fixture
def client(tmp_path_factory, monkeypatch):
    from texbake.service.core import config as settings
    from texbake.service.core import db
    from texbake.service.main import create_app
    from texbake.service.worker import tasks

    monkeypatch.setenv("BAKE_DATA_DIR", str(tmp_path_factory.mktemp("data")))
    monkeypatch.setenv("BAKE_MAX_SIZE", "2048")
    settings.get_settings.cache_clear()
    tasks.queue.cache_clear()  # its huey queue lives in this data folder
    db.upgrade(settings.get_settings().database)  # as `texbake serve` does first
    try:
        with TestClient(create_app()) as c:
            yield c
    finally:
        settings.get_settings.cache_clear()
        tasks.queue.cache_clear()
