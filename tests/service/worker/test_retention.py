"""Retention (texbake.service.worker.retention): expired jobs go with their folders, left-overs of dead
processes go, live jobs and recent files stay; on a real SQLite jobs table and data folder."""

import os
import time
from datetime import timedelta

from sqlalchemy import update

from texbake.service.core import crud, db
from texbake.service.core.config import Settings
from texbake.service.core.models import Job, now
from texbake.service.worker.retention import LEFTOVER_SECONDS, collect


def job(session, settings, key, state, hours_ago):
    made, _ = crud.create_job(session, key=key, client="c", mesh_name="m.obj", settings={})
    session.execute(update(Job).where(Job.id == made.id).values(state=state, updated=now() - timedelta(hours=hours_ago)))
    session.commit()
    folder = settings.data_dir / "jobs" / made.id
    (folder / "out").mkdir(parents=True)
    (folder / "out" / "albedo.png").write_bytes(b"png")
    return made.id


def age(path, seconds):
    then = time.time() - seconds
    os.utime(path, (then, then))


def test_collect_expires_old_jobs_and_left_overs_only(tmp_path):
    settings = Settings(data_dir=tmp_path, keep_hours=48, keep_failed_hours=2)
    db.upgrade(settings.database)
    with db.sessions(settings.database)() as session:
        old_done = job(session, settings, "a", "done", 50)
        new_done = job(session, settings, "b", "done", 10)
        old_failed = job(session, settings, "c", "failed", 3)
        queued = job(session, settings, "d", "queued", 500)  # waiting, however long: never expired
    orphan = tmp_path / "jobs" / ("f" * 32)  # a folder whose row was never committed
    orphan.mkdir()
    fresh_orphan = tmp_path / "jobs" / ("e" * 32)  # maybe being staged right now
    fresh_orphan.mkdir()
    half = settings.data_dir / "jobs" / new_done / "out.tmp.1"  # a bake that lost its lease and died before cleaning
    half.mkdir()
    (tmp_path / "uploads").mkdir()
    stale_upload, fresh_upload = tmp_path / "uploads" / "x.obj", tmp_path / "uploads" / "y.obj"
    stale_upload.write_bytes(b"v")
    fresh_upload.write_bytes(b"v")
    # a request's parts, each in a folder of its own: one long over, one with a part still arriving
    stale_parts, arriving = tmp_path / "uploads" / ("1" * 32), tmp_path / "uploads" / ("2" * 32)
    for folder in (stale_parts, arriving):
        folder.mkdir()
        (folder / "m.obj").write_bytes(b"v")
        (folder / "m.mtl").write_bytes(b"newmtl a")
    for path in (orphan, half, stale_upload, stale_parts, stale_parts / "m.obj", stale_parts / "m.mtl", arriving, arriving / "m.obj"):
        age(path, LEFTOVER_SECONDS + 60)

    collected = collect(settings)
    assert sorted(collected.jobs) == sorted([old_done, old_failed])
    assert sorted(collected.leftovers) == sorted([f"jobs/{orphan.name}", f"jobs/{new_done}/out.tmp.1", "uploads/x.obj",
                                                  f"uploads/{stale_parts.name}"])
    assert not stale_parts.exists() and (arriving / "m.mtl").exists()
    assert sorted(p.name for p in (tmp_path / "jobs").iterdir()) == sorted([new_done, queued, fresh_orphan.name])
    assert fresh_upload.exists() and (settings.data_dir / "jobs" / new_done / "out" / "albedo.png").exists()
    with db.sessions(settings.database)() as session:
        assert crud.get_job(session, old_done) is None and crud.get_job(session, new_done) is not None
        # an expired done job no longer answers for its key: the same upload bakes again
        assert crud.create_job(session, key="a", client="c", mesh_name="m.obj", settings={})[1]
    assert collect(settings).jobs == []  # nothing more to do
