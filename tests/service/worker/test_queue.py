"""The queue: JSON messages (never pickle), no stored results, on SQLite and on Redis."""

import pickle
from datetime import datetime

import pytest

from texbake.service.core.config import Settings
from texbake.service.worker.queue import BadMessage, JsonSerializer, make_huey


@pytest.fixture(params=["sqlite", "redis"])
def huey(request, tmp_path):
    redis_url = request.getfixturevalue("own_redis").url if request.param == "redis" else None
    return make_huey(Settings(data_dir=tmp_path, redis_url=redis_url))


def test_messages_are_json_and_round_trip(huey):
    ran = []
    bake = huey.task(name="run_bake")(lambda job_id: ran.append(job_id))
    bake("abc123")
    bake.schedule(("later",), eta=datetime(2030, 1, 2, 3, 4, 5))
    assert [(t.name, t.args) for t in huey.pending()] == [("run_bake", ("abc123",)), ("run_bake", ("later",))]
    data = huey.storage.dequeue()
    assert data.startswith(b'{"message":') and b"abc123" in data
    huey.execute(huey.deserialize_task(data))
    assert ran == ["abc123"] and huey.result_count() == 0  # results are not stored
    assert huey.dequeue().eta == datetime(2030, 1, 2, 3, 4, 5)


def test_a_pickled_message_is_refused_unread():
    """Whoever can write to the queue cannot run code in the workers."""
    class Boom:
        def __reduce__(self):
            return (exec, ("raise SystemExit('ran code from the queue')",))

    with pytest.raises(BadMessage, match="not a texbake queue message"):
        JsonSerializer().deserialize(pickle.dumps(Boom()))
    with pytest.raises(BadMessage, match="unknown tag"):
        JsonSerializer().deserialize(b'{"exec": "print(1)"}')
