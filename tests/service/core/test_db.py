"""The jobs table, on SQLite and on PostgreSQL: claim, heartbeat, cancel, the reaper's
bounded re-queue, deduplication under concurrency, and the lease that fences a bake."""

import threading
from datetime import timedelta

import pytest
from sqlalchemy import text

from texbake.service.core import db


@pytest.fixture(params=["sqlite", "postgresql"])
def url(request, tmp_path):
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'jobs.db'}"
    return request.getfixturevalue("postgres_url")


def make(url):
    Session = db.sessions(url)
    session = Session()
    job, created = db.create_job(session, key="k", client="c", mesh_name="m.obj", settings={"size": 8})
    return session, job, created


def age(session, job_id, seconds, column="heartbeat"):
    session.execute(db.update(db.Job).where(db.Job.id == job_id).values({column: db.now() - timedelta(seconds=seconds)}))
    session.commit()


def test_create_is_deduplicated_and_claimed_once(url):
    session, job, created = make(url)
    again, created_again = db.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})
    assert created and not created_again and again.id == job.id
    claimed = db.claim(session, job.id)
    assert claimed.attempts == 1 and claimed.lease == 1
    assert db.claim(session, job.id) is None  # running already
    assert db.beat(session, job.id, 1, progress=0.5) == "running"


def test_reaper_requeues_stale_jobs_then_fails_them(url):
    session, job, _ = make(url)
    for attempt in (1, 2):
        db.claim(session, job.id)
        assert db.reap(session, stale_seconds=30, max_attempts=3) == ([], [])  # fresh heartbeat
        age(session, job.id, 60)
        assert db.reap(session, stale_seconds=30, max_attempts=3) == ([job.id], [])
        session.refresh(job)
        assert job.state == "queued" and job.attempts == attempt
    db.claim(session, job.id)
    age(session, job.id, 60)
    assert db.reap(session, stale_seconds=30, max_attempts=3) == ([], [job.id])
    session.refresh(job)
    assert job.state == "failed" and "stopped answering 3 times" in job.error
    # a failed job lets go of its key: the same upload is baked again
    assert db.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})[1]


def test_cancel_wins_over_finish(url):
    session, job, _ = make(url)
    db.claim(session, job.id)
    assert db.cancel(session, job.id) and not db.cancel(session, job.id)
    assert db.beat(session, job.id, 1) == "cancelled"
    assert not db.finish(session, job.id, 1, "done", report={})
    session.refresh(job)
    assert job.state == "cancelled"
    fresh, created = db.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})
    assert created and fresh.id != job.id  # dedup returns only live or done jobs


def test_a_bake_whose_lease_was_taken_can_neither_beat_nor_finish(url):
    """The reaper re-queues a job whose heartbeat went stale (its worker was only slow), a
    second worker claims it: the first one's lease is over."""
    session, job, _ = make(url)
    first = db.claim(session, job.id).lease
    age(session, job.id, 60)
    db.reap(session, stale_seconds=30, max_attempts=3)
    assert db.beat(session, job.id, first) == "taken" and not db.holds(session, job.id, first)  # queued again
    second = db.claim(session, job.id).lease
    assert second == first + 1
    assert db.beat(session, job.id, first) == "taken" and not db.holds(session, job.id, first)
    assert not db.finish(session, job.id, first, "done", report={}) and not db.release(session, job.id, first)
    assert db.holds(session, job.id, second) and db.finish(session, job.id, second, "done", report={"ok": 1})
    session.refresh(job)
    assert job.state == "done" and job.attempts == 2


def test_twenty_concurrent_identical_creates_make_one_job(url):
    """Check-then-insert made 10 jobs of 20 on SQLite and 14 on PostgreSQL; the unique key
    makes one, and the other 19 calls get it."""
    db.sessions(url)  # the table exists before the race
    start = threading.Barrier(20)
    answers = []

    def create():
        with db.sessions(url)() as session:
            start.wait()
            job, created = db.create_job(session, key="same", client="c", mesh_name="m.obj", settings={})
            answers.append((job.id, created))

    threads = [threading.Thread(target=create) for _ in range(20)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(answers) == 20 and len({i for i, _ in answers}) == 1 and sum(c for _, c in answers) == 1, answers
    with db.sessions(url)() as session:
        assert session.scalar(text("SELECT count(*) FROM jobs")) == 1


def test_stranded_lists_queued_jobs_older_than_the_grace(url):
    session, job, _ = make(url)
    assert db.stranded(session, 60) == []
    age(session, job.id, 120, column="updated")
    assert db.stranded(session, 60) == [job.id]
    db.claim(session, job.id)
    assert db.stranded(session, 60) == []


def test_a_table_from_before_the_unique_key_is_upgraded(tmp_path):
    """An older jobs table (no lease, no live_key, duplicates from the old race) gets the
    columns; the newest live job of each key holds it."""
    from sqlalchemy import create_engine

    url = f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_engine(url)
    with engine.begin() as conn:
        conn.execute(text("CREATE TABLE jobs (id VARCHAR(32) PRIMARY KEY, key VARCHAR(64), client VARCHAR(128), state VARCHAR(16), "
                          "mesh_name VARCHAR(255), settings TEXT, progress FLOAT, error TEXT, report TEXT, attempts INTEGER, "
                          "created DATETIME, updated DATETIME, heartbeat DATETIME)"))
        for i, (key, state, created) in enumerate([("a", "done", "2024-01-01"), ("a", "queued", "2024-01-02"), ("b", "failed", "2024-01-01")]):
            conn.execute(text("INSERT INTO jobs VALUES (:id, :key, 'c', :state, 'm', '{}', 0, NULL, NULL, 0, :created, :created, NULL)"),
                         {"id": f"j{i}", "key": key, "state": state, "created": created})
    engine.dispose()
    with db.sessions(url)() as session:
        assert dict(session.execute(text("SELECT id, live_key FROM jobs")).all()) == {"j0": None, "j1": "a", "j2": None}
        assert db.create_job(session, key="a", client="c", mesh_name="m", settings={})[0].id == "j1"
        assert db.create_job(session, key="b", client="c", mesh_name="m", settings={})[1]
