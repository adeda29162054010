"""The jobs table on SQLite: claim, heartbeat, cancel, and the reaper's bounded re-queue."""

from datetime import timedelta

from service import db


def make(tmp_path):
    Session = db.sessions(f"sqlite:///{tmp_path / 'jobs.db'}")
    session = Session()
    job, created = db.create_job(session, key="k", client="c", mesh_name="m.obj", settings={"size": 8})
    return session, job, created


def age(session, job_id, seconds):
    job = session.get(db.Job, job_id)
    job.heartbeat = db.now() - timedelta(seconds=seconds)
    session.commit()


def test_create_is_deduplicated_and_claimed_once(tmp_path):
    session, job, created = make(tmp_path)
    again, created_again = db.create_job(session, key="k", client="c", mesh_name="m.obj", settings={})
    assert created and not created_again and again.id == job.id
    assert db.claim(session, job.id).attempts == 1
    assert db.claim(session, job.id) is None  # running already
    assert db.beat(session, job.id, progress=0.5) == "running"


def test_reaper_requeues_stale_jobs_then_fails_them(tmp_path):
    session, job, _ = make(tmp_path)
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


def test_cancel_wins_over_finish(tmp_path):
    session, job, _ = make(tmp_path)
    db.claim(session, job.id)
    assert db.cancel(session, job.id) and not db.cancel(session, job.id)
    assert db.beat(session, job.id) == "cancelled"
    db.finish(session, job.id, "done", report={})
    session.refresh(job)
    assert job.state == "cancelled"
