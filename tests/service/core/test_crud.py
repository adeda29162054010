"""The queries (texbake.service.core.crud), on SQLite and on PostgreSQL: claim, heartbeat,
cancel, the reaper's bounded re-queue, deduplication and the per-client limit under
concurrency, and the lease that fences a bake."""

import threading
from datetime import timedelta

import pytest
from sqlalchemy import text, update

from texbake.service.core import crud, db
from texbake.service.core.models import Job, now


@pytest.fixture(params=["sqlite", "postgresql"])
def url(request, tmp_path):
    url = f"sqlite:///{tmp_path / 'jobs.db'}" if request.param == "sqlite" else request.getfixturevalue("postgres_url")
    db.upgrade(url)
    return url


def make(url):
    Session = db.sessions(url)
    session = Session()
    job, created = crud.create_job(session, key="k", client="c", mesh_name="m.obj", settings={"size": 8})
    return session, job, created


def age(session, job_id, seconds, column="heartbeat"):
    session.execute(update(Job).where(Job.id == job_id).values({column: now() - timedelta(seconds=seconds)}))
    session.commit()


def test_create_is_deduplicated_and_claimed_once(url):
    session, job, created = make(url)
    again, created_again = crud.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})
    assert created and not created_again and again.id == job.id
    claimed = crud.claim(session, job.id)
    assert claimed.attempts == 1 and claimed.lease == 1
    assert crud.claim(session, job.id) is None  # running already
    assert crud.beat(session, job.id, 1, progress=0.5) == "running"


def test_reaper_requeues_stale_jobs_then_fails_them(url):
    session, job, _ = make(url)
    for attempt in (1, 2):
        crud.claim(session, job.id)
        assert crud.reap(session, stale_seconds=30, max_attempts=3) == ([], [])  # fresh heartbeat
        age(session, job.id, 60)
        assert crud.reap(session, stale_seconds=30, max_attempts=3) == ([job.id], [])
        session.refresh(job)
        assert job.state == "queued" and job.attempts == attempt
    crud.claim(session, job.id)
    age(session, job.id, 60)
    assert crud.reap(session, stale_seconds=30, max_attempts=3) == ([], [job.id])
    session.refresh(job)
    assert job.state == "failed" and "stopped answering 3 times" in job.error
    # a failed job lets go of its key: the same upload is baked again
    assert crud.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})[1]


def test_cancel_wins_over_finish(url):
    session, job, _ = make(url)
    crud.claim(session, job.id)
    assert crud.cancel(session, job.id) and not crud.cancel(session, job.id)
    assert crud.beat(session, job.id, 1) == "cancelled"
    assert not crud.finish(session, job.id, 1, "done", report={})
    session.refresh(job)
    assert job.state == "cancelled"
    fresh, created = crud.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})
    assert created and fresh.id != job.id  # dedup returns only live or done jobs


def test_a_bake_whose_lease_was_taken_can_neither_beat_nor_finish(url):
    """The reaper re-queues a job whose heartbeat went stale (its worker was only slow), a
    second worker claims it: the first one's lease is over."""
    session, job, _ = make(url)
    first = crud.claim(session, job.id).lease
    age(session, job.id, 60)
    crud.reap(session, stale_seconds=30, max_attempts=3)
    assert crud.beat(session, job.id, first) == "taken" and not crud.holds(session, job.id, first)  # queued again
    second = crud.claim(session, job.id).lease
    assert second == first + 1
    assert crud.beat(session, job.id, first) == "taken" and not crud.holds(session, job.id, first)
    assert not crud.finish(session, job.id, first, "done", report={}) and not crud.release(session, job.id, first)
    assert crud.holds(session, job.id, second) and crud.finish(session, job.id, second, "done", report={"ok": 1})
    session.refresh(job)
    assert job.state == "done" and job.attempts == 2


def test_twenty_concurrent_identical_creates_make_one_job(url):
    """Check-then-insert made 10 jobs of 20 on SQLite and 14 on PostgreSQL; the unique key
    makes one, and the other 19 calls get it."""
    start = threading.Barrier(20)
    answers = []

    def create():
        with db.sessions(url)() as session:
            start.wait()
            job, created = crud.create_job(session, key="same", client="c", mesh_name="m.obj", settings={})
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
    assert crud.stranded(session, 60) == []
    age(session, job.id, 120, column="updated")
    assert crud.stranded(session, 60) == [job.id]
    crud.claim(session, job.id)
    assert crud.stranded(session, 60) == []


def test_the_limit_is_exact_under_concurrent_creates(url):
    """40 concurrent distinct creates of one client with 10 allowed: counted under the
    client's lock in the inserting transaction (a count before the insert lets more
    through), exactly 10. Another client's creates are not counted against it."""
    start = threading.Barrier(48)
    answers: list[tuple[str, str]] = []

    def create(client, i):
        with db.sessions(url)() as session:
            start.wait()
            try:
                crud.create_job(session, key=f"{client}{i}", client=client, mesh_name="m.obj", settings={}, limit=10)
                answers.append((client, "created"))
            except crud.LimitReached as exc:
                assert (exc.unfinished, exc.limit) == (10, 10), exc
                answers.append((client, "refused"))

    threads = [threading.Thread(target=create, args=("a", i)) for i in range(40)] + [threading.Thread(target=create, args=("b", i)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(answers).count(("a", "created")) == 10 and answers.count(("a", "refused")) == 30, answers
    assert answers.count(("b", "created")) == 8
    with db.sessions(url)() as session:
        assert crud.unfinished(session, "a") == 10 and crud.unfinished(session, "b") == 8
        job = crud.list_jobs(session, "a", 0, 1)[1][0]
        crud.cancel(session, job.id)  # one finished: one more may be made
        assert crud.create_job(session, key="a-again", client="a", mesh_name="m.obj", settings={}, limit=10)[1]
        with pytest.raises(crud.LimitReached):
            crud.create_job(session, key="a-more", client="a", mesh_name="m.obj", settings={}, limit=10)


def test_a_session_holds_no_connection_between_queries(url):
    """Each query is its own transaction: between calls (while a route copies an upload,
    or waits for its answer to be sent) the session gives its connection back."""
    pool = db.sessions(url).kw["bind"].pool
    with db.sessions(url)() as session:
        job, _ = crud.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})
        assert pool.checkedout() == 0
        for call in (lambda: crud.get_job(session, job.id), lambda: crud.unfinished(session, "c"), lambda: crud.live_job(session, "k"),
                     lambda: crud.list_jobs(session, None, 0, 10), lambda: crud.claim(session, job.id),
                     lambda: crud.beat(session, job.id, 1), lambda: crud.live_workers(session, 10)):
            assert call() is not None
            assert pool.checkedout() == 0, call
        assert crud.get_job(session, job.id).state == "running"
