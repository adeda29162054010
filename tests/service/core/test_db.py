"""The jobs database's engine and migrations (texbake.service.core.db and
texbake/service/migrations), on SQLite and on PostgreSQL: a database made before
migrations, with jobs in it, is taken as it is and loses none; a new one gets exactly the
models' schema; processes that start together migrate one at a time; waits are bounded."""

import json
import subprocess
import sys
import time
from datetime import datetime, timezone

import pytest
from conftest import execute, make_old_database, old_jobs
from sqlalchemy import create_engine, text
from sqlalchemy.exc import TimeoutError as PoolTimeout

from texbake.service.core import crud, db
from texbake.service.core.models import Base


@pytest.fixture(params=["sqlite", "postgresql"])
def url(request, tmp_path):
    return f"sqlite:///{tmp_path / 'jobs.db'}" if request.param == "sqlite" else request.getfixturevalue("postgres_url")


def test_a_database_made_before_migrations_keeps_every_job(url):
    jobs = list(old_jobs())
    make_old_database(url, jobs)
    execute(url, "INSERT INTO workers VALUES ('host:1', 2, :seen)", seen=datetime(2026, 11, 30, tzinfo=timezone.utc))
    assert db.revision(url) is None
    assert db.upgrade(url) == (None, "0001")  # stamped: the tables were today's already
    assert db.revision(url) == "0001" and db.upgrade(url) == ("0001", "0001")
    with db.sessions(url)() as session:
        total, listed = crud.list_jobs(session, None, 0, 100)
        assert total == len(jobs) and {j.id for j in listed} == {j["id"] for j in jobs}
        for job in jobs:
            read = crud.get_job(session, job["id"]).as_dict()
            assert (read["state"], read["mesh"], read["settings"], read["error"], read["attempts"]) == (
                job["state"], job["mesh_name"], json.loads(job["settings"]), job["error"], job["attempts"]), read
            assert read["report"] == (json.loads(job["report"]) if job["report"] else None)
            created = datetime.fromisoformat(read["created"])
            assert (created if created.tzinfo else created.replace(tzinfo=timezone.utc)) == job["created"]  # SQLite keeps no time zone
        # deduplication still holds its keys, and the table takes new jobs
        assert crud.create_job(session, key="k2", client="c", mesh_name="m", settings={})[0].id == jobs[2]["id"]
        assert crud.create_job(session, key="k3", client="c", mesh_name="m", settings={})[1]  # k3 failed: let go of its key
        assert session.scalar(text("SELECT count(*) FROM workers")) == 1


def test_a_jobs_table_from_before_the_unique_key_gets_its_columns(tmp_path):
    """An older jobs table still (no lease, no live_key, duplicates from the old race): the
    first migration adds the columns; the newest live job of each key holds it."""
    url = f"sqlite:///{tmp_path / 'old.db'}"
    execute(url, "CREATE TABLE jobs (id VARCHAR(32) PRIMARY KEY, key VARCHAR(64), client VARCHAR(128), state VARCHAR(16), "
                 "mesh_name VARCHAR(255), settings TEXT, progress FLOAT, error TEXT, report TEXT, attempts INTEGER, "
                 "created DATETIME, updated DATETIME, heartbeat DATETIME)")
    for i, (key, state, created) in enumerate([("a", "done", "2024-01-01"), ("a", "queued", "2024-01-02"), ("b", "failed", "2024-01-01")]):
        execute(url, "INSERT INTO jobs VALUES (:id, :key, 'c', :state, 'm', '{}', 0, NULL, NULL, 0, :created, :created, NULL)",
                id=f"j{i}", key=key, state=state, created=created)
    assert db.upgrade(url) == (None, "0001")
    with db.sessions(url)() as session:
        assert dict(session.execute(text("SELECT id, live_key FROM jobs")).all()) == {"j0": None, "j1": "a", "j2": None}
        assert dict(session.execute(text("SELECT id, lease FROM jobs")).all()) == {"j0": 0, "j1": 0, "j2": 0}
        session.commit()
        assert crud.create_job(session, key="a", client="c", mesh_name="m", settings={})[0].id == "j1"
        assert crud.create_job(session, key="b", client="c", mesh_name="m", settings={})[1]
        assert crud.live_workers(session, 60) == (0, 0)  # the workers table was made


def test_a_new_database_gets_exactly_the_models_schema(url):
    """Migrated from nothing, the database is what the models say: Alembic's comparison
    finds no difference (a model changed without a migration fails here)."""
    from alembic.autogenerate import compare_metadata
    from alembic.runtime.migration import MigrationContext

    assert db.upgrade(url) == (None, "0001")
    engine = create_engine(url)
    try:
        with engine.connect() as conn:
            assert compare_metadata(MigrationContext.configure(conn), Base.metadata) == []
    finally:
        engine.dispose()


GO = """
import pathlib, sys, time
from texbake.service.core import db
folder = pathlib.Path(sys.argv[2])
(folder / f"ready-{sys.argv[3]}").touch()
while not (folder / "go").exists():
    time.sleep(0.005)
print(db.upgrade(sys.argv[1]))
"""


def test_processes_starting_together_migrate_once(url, tmp_path):
    """Six processes migrate a new database at the same moment (an API and its workers
    starting): one makes the tables, the others wait for its lock and find them made."""
    n = 6
    procs = [subprocess.Popen([sys.executable, "-c", GO, url, str(tmp_path), str(i)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(n)]
    end = time.monotonic() + 120
    while len(list(tmp_path.glob("ready-*"))) < n and time.monotonic() < end:
        time.sleep(0.05)
    (tmp_path / "go").touch()
    answers = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0] * n, [err[-2000:] for _, err in answers]
    outs = sorted(out.strip() for out, _ in answers)
    assert outs == ["('0001', '0001')"] * (n - 1) + ["(None, '0001')"], outs
    assert db.revision(url) == "0001"


def test_waiting_for_a_connection_is_bounded(tmp_path, monkeypatch):
    """Every pooled connection taken: the next query gives up after
    BAKE_DATABASE_WAIT_SECONDS (the API answers 503), it does not wait 30 s."""
    from texbake.service.core import config

    monkeypatch.setenv("BAKE_DATABASE_WAIT_SECONDS", "0.5")
    config.get_settings.cache_clear()
    url = f"sqlite:///{tmp_path / 'jobs.db'}"
    try:
        db.upgrade(url)
        engine = db.sessions(url).kw["bind"]
        held = [engine.connect() for _ in range(engine.pool.size() + engine.pool._max_overflow)]
        began = time.monotonic()
        with pytest.raises(PoolTimeout), db.sessions(url)() as session:
            crud.get_job(session, "0" * 32)
        assert 0.4 < time.monotonic() - began < 3
        held.pop().close()
        with db.sessions(url)() as session:
            assert crud.get_job(session, "0" * 32) is None
        for conn in held:
            conn.close()
    finally:
        db.sessions(url).kw["bind"].dispose()
        db.sessions.cache_clear()
        config.get_settings.cache_clear()


def test_waiting_for_a_lock_is_bounded(url, monkeypatch):
    """Another connection holds the lock a create takes (SQLite's write lock; the client's
    advisory lock on PostgreSQL): the create gives up after BAKE_DATABASE_WAIT_SECONDS
    with an OperationalError (the API's 503), and succeeds once the lock is let go."""
    from sqlalchemy.exc import OperationalError

    from texbake.service.core import config

    monkeypatch.setenv("BAKE_DATABASE_WAIT_SECONDS", "0.5")
    config.get_settings.cache_clear()
    db.upgrade(url)
    holder = create_engine(url)
    try:
        with holder.connect() as conn:
            db.write_lock(conn, "client:c")
            began = time.monotonic()
            with pytest.raises(OperationalError), db.sessions(url)() as session:
                crud.create_job(session, key="k", client="c", mesh_name="m", settings={})
            assert 0.4 < time.monotonic() - began < 3
            with db.sessions(url)() as session:  # another client's lock is free (SQLite: one lock for all)
                if url.startswith("postgresql"):
                    assert crud.create_job(session, key="k2", client="d", mesh_name="m", settings={})[1]
            conn.rollback()
        with db.sessions(url)() as session:
            assert crud.create_job(session, key="k", client="c", mesh_name="m", settings={})[1]
    finally:
        holder.dispose()
        db.sessions(url).kw["bind"].dispose()
        db.sessions.cache_clear()
        config.get_settings.cache_clear()
