"""Fixtures and helpers shared by the test modules (import helpers with ``from conftest import ...``)."""

import contextlib
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timedelta, timezone
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

ROOT = Path(__file__).resolve().parents[1]  # the repository
SHARED = ROOT.parent / "shared"
MESHES = SHARED / "meshes"


def pytest_configure(config):
    config.addinivalue_line("markers", "xatlas_failure: relies on a real xatlas failure (a hang or a crash a new xatlas may fix)")
    # the command line keeps atlases for later bakes: in a folder of this run, not the user's
    os.environ["TEXBAKE_CACHE"] = tempfile.mkdtemp(prefix="texbake-test-cache-")


@pytest.fixture(scope="session")
def meshes() -> Path:
    if not MESHES.is_dir():
        pytest.fail(f"test meshes not found at {MESHES}: ../shared must sit beside the repo")
    return MESHES


def run_cli(*args, cwd=None, timeout=300):
    """Run the ``texbake`` command line as a real process; the CompletedProcess (text)."""
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"} | {"COLUMNS": "200"}
    return subprocess.run(
        [sys.executable, "-m", "texbake.cli", *map(str, args)],
        capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env,
    )


def mixed_uv_scene(path: Path, scale: float = 1.0) -> dict:
    """Write a glTF scene (``path``: .glb or .gltf) of two parts, made with trimesh:
    ``crate``, a unit box whose 12 triangles each lie in a cell of a 4 x 3 grid of the UV
    square (the grid scaled by ``scale`` towards the origin), and ``ball``, an icosphere
    beside it with no UVs. Returns the crate's ``{"positions": (12, 3, 3), "uv": (12, 3, 2)}``
    per face corner, in face order, to compare with what a load keeps."""
    import numpy as np
    import trimesh
    from trimesh.visual import TextureVisuals

    box = trimesh.creation.box(extents=(1, 1, 1))
    box.unmerge_vertices()  # each triangle its own corners: its own UV island
    uv = np.zeros((len(box.vertices), 2))
    for i, face in enumerate(box.faces):
        row, col = divmod(i // 2, 4)
        x, y, s = col * 0.25 * scale, row / 3 * scale, 0.22 * scale
        uv[face] = [(x, y), (x + s, y), (x + s, y + s)] if i % 2 == 0 else [(x, y), (x + s, y + s), (x, y + s)]
    box.visual = TextureVisuals(uv=uv)
    ball = trimesh.creation.icosphere(subdivisions=2)
    ball.apply_translation((3, 0, 0))
    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="crate", geom_name="crate")
    scene.add_geometry(ball, node_name="ball", geom_name="ball")
    scene.export(path)
    return {"positions": box.vertices[box.faces], "uv": uv[box.faces]}


def two_material_scene(path: Path) -> None:
    """Write a glTF scene (``path``: .glb) of two materials, made with trimesh: ``body``, a
    unit box whose 12 triangles each lie in a cell of a 4 x 3 grid of the UV square (its
    own UVs usable), and ``wheels``, two icospheres beside it without UVs (as the
    CesiumMilkTruck's glass has none)."""
    import numpy as np
    import trimesh
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial

    box = trimesh.creation.box(extents=(1, 1, 1))
    box.unmerge_vertices()
    uv = np.zeros((len(box.vertices), 2))
    for i, face in enumerate(box.faces):
        row, col = divmod(i // 2, 4)
        x, y, s = col * 0.25, row / 3, 0.22
        uv[face] = [(x, y), (x + s, y), (x + s, y + s)] if i % 2 == 0 else [(x, y), (x + s, y + s), (x, y + s)]
    box.visual = TextureVisuals(uv=uv, material=PBRMaterial(name="body"))
    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="body", geom_name="body")
    for k, x in enumerate((-1.5, 1.5)):
        ball = trimesh.creation.icosphere(subdivisions=2, radius=0.4).apply_translation((x, -0.6, 0))
        ball.visual = TextureVisuals(material=PBRMaterial(name="wheels"))
        scene.add_geometry(ball, node_name=f"wheel{k}", geom_name=f"wheel{k}")
    scene.export(path)


def udim_boxes(path: Path, tiles: int = 4) -> dict:
    """Write an OBJ (``path``) of ``tiles`` unit boxes in a row, box ``k``'s 12 triangles
    each in a cell of a 4 x 3 grid of UDIM tile ``1001 + k`` (u from k to k + 1): a UDIM
    asset. Returns ``{"uv": (12 tiles, 3, 2) per face corner, "tile": (12 tiles,)}`` in
    face order."""
    import numpy as np
    import trimesh

    lines, uvs, tile_of, base = [], [], [], 0
    for k in range(tiles):
        box = trimesh.creation.box(extents=(1, 1, 1))
        box.unmerge_vertices()
        box.apply_translation((1.5 * k, 0, 0))
        for i, face in enumerate(box.faces):
            row, col = divmod(i // 2, 4)
            x, y, s = k + col * 0.25 + 0.02, row / 3 + 0.02, 0.2
            corners = [(x, y), (x + s, y), (x + s, y + s)] if i % 2 == 0 else [(x, y), (x + s, y + s), (x, y + s)]
            for j, (a, b) in zip(face, corners, strict=True):
                lines.append("v {:.9g} {:.9g} {:.9g}".format(*box.vertices[j]))
                lines.append(f"vt {a:.9g} {b:.9g}")
            lines.append("f " + " ".join(f"{base + n}/{base + n}" for n in (1, 2, 3)))
            base += 3
            uvs.append(corners)
            tile_of.append(1001 + k)
    path.write_text("\n".join(lines) + "\n")
    return {"uv": np.array(uvs, dtype=np.float64), "tile": np.array(tile_of)}


def glb_with_image_uri(uri):
    doc = json.dumps({"asset": {"version": "2.0"}, "images": [{"uri": uri}]}).encode()
    doc += b" " * (-len(doc) % 4)
    return struct.pack("<4sII", b"glTF", 2, 20 + len(doc)) + struct.pack("<I4s", len(doc), b"JSON") + doc


def glb_with_accessor(count):
    """A GLB whose position accessor claims ``count`` items of a 36-byte buffer view."""
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 44}],
           "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}], "nodes": [{"mesh": 0}]}
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    binary = bytes(44)
    body = struct.pack("<I4s", len(j), b"JSON") + j + struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


# --- a real browser ------------------------------------------------------------------

def chromium() -> str:
    """Debian's chromium (no browser is downloaded). Missing, the test is skipped only
    when it cannot be installed (not root) and not under CI (CI=true fails instead)."""
    import shutil

    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found:
        return found
    message = "chromium not found: `apt-get install chromium` (scripts/run installs it when running as root)"
    if os.environ.get("CI", "").lower() in ("1", "true", "yes") or os.geteuid() == 0:
        pytest.fail(message)
    pytest.skip(message)


def keep_artefact(path: Path) -> None:
    """Copy a file (a screenshot) into the folder TEXBAKE_ARTEFACTS names, if set."""
    import shutil

    artefacts = os.environ.get("TEXBAKE_ARTEFACTS")
    if artefacts:
        Path(artefacts).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, Path(artefacts) / path.name)


# --- Redis and PostgreSQL servers -------------------------------------------------------
# Tests of the service against the real servers: the machine's shared ones (a database of
# its own on PostgreSQL 127.0.0.1:5432), or instances a test starts itself (redis-server,
# initdb/pg_ctl) to stop, flush or restart them. Without them the test is skipped, and
# fails under CI (CI=true or TEXBAKE_REQUIRE_SERVICES=1).

PG_BIN = Path("/usr/lib/postgresql/15/bin")


def need(why: str):
    """Skip for ``why``, or fail under CI."""
    if os.environ.get("TEXBAKE_REQUIRE_SERVICES") or os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        pytest.fail(why)
    pytest.skip(why)


@pytest.fixture
def postgres_url():
    """A fresh database on the shared PostgreSQL (dropped afterwards): its SQLAlchemy URL."""
    try:
        import psycopg

        with psycopg.connect("host=127.0.0.1 port=5432 user=postgres dbname=postgres", connect_timeout=3, autocommit=True) as conn:
            name = f"texbake_test_{os.getpid()}_{time.monotonic_ns() % 10**9}"
            conn.execute(f'CREATE DATABASE "{name}"')
    except Exception as exc:  # any reason at all: report it
        need(f"PostgreSQL 127.0.0.1:5432 needed: {type(exc).__name__}: {exc}")
    url = f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
    yield url
    from sqlalchemy.orm import close_all_sessions

    from texbake.service.core import db

    close_all_sessions()  # the test's sessions give their connections back, which go with the engine
    db.sessions(url).kw["bind"].dispose()
    db.sessions.cache_clear()
    with psycopg.connect("host=127.0.0.1 port=5432 user=postgres dbname=postgres", autocommit=True) as conn:
        conn.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


class OwnRedis:
    """A redis-server of the test's own on a free port, no persistence: stop() and start()
    again give an empty one, as a restarted Redis without its dump does."""

    def __init__(self, folder: Path):
        self.port, self.folder = free_port(), folder
        self.url = f"redis://127.0.0.1:{self.port}/0"
        self.process: subprocess.Popen | None = None

    def start(self):
        import redis

        self.process = subprocess.Popen(["redis-server", "--port", str(self.port), "--bind", "127.0.0.1", "--save", "", "--appendonly", "no",
                                         "--dir", str(self.folder)], stdout=subprocess.DEVNULL)
        client = redis.Redis(port=self.port)
        for _ in range(100):
            try:
                client.ping()
                return self
            except redis.ConnectionError:
                time.sleep(0.05)
        raise RuntimeError(f"redis-server on port {self.port} did not start")

    def stop(self):
        if self.process is not None:
            self.process.kill()
            self.process.wait()
            self.process = None

    def flush(self):
        import redis

        redis.Redis(port=self.port).flushall()


@pytest.fixture
def own_redis(tmp_path_factory):
    import shutil

    if shutil.which("redis-server") is None:
        need("redis-server needed (to start a Redis of the test's own)")
    server = OwnRedis(tmp_path_factory.mktemp("redis")).start()
    yield server
    server.stop()


class OwnPostgres:
    """A PostgreSQL cluster of the test's own (initdb, pg_ctl) on a free port; as root, it
    runs as the ``postgres`` user (PostgreSQL refuses root)."""

    def __init__(self, folder: Path):
        self.port, self.folder = free_port(), folder
        self.url = f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/postgres"
        self._as = ["runuser", "-u", "postgres", "--"] if os.geteuid() == 0 else []
        if self._as:
            import shutil

            shutil.chown(folder, "postgres")
        subprocess.run([*self._as, str(PG_BIN / "initdb"), "-D", str(folder / "db"), "-A", "trust", "-U", "postgres", "--no-sync"],
                       check=True, capture_output=True)

    def _ctl(self, *args):
        subprocess.run([*self._as, str(PG_BIN / "pg_ctl"), "-D", str(self.folder / "db"), "-w", *args], check=True, capture_output=True)

    def start(self):
        options = f"-p {self.port} -k {self.folder} -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=200"
        self._ctl("-o", options, "-l", str(self.folder / "log"), "start")
        return self

    def stop(self):
        self._ctl("-m", "fast", "stop")


@pytest.fixture
def own_postgres():
    import shutil
    import tempfile

    if not (PG_BIN / "initdb").exists():
        need(f"PostgreSQL's initdb and pg_ctl needed in {PG_BIN}")
    folder = Path(tempfile.mkdtemp(prefix="texbake-pg-"))  # not under pytest's 0700 folders: the postgres user works here
    try:
        server = OwnPostgres(folder).start()
        yield server
        from texbake.service.core import db

        db.sessions.cache_clear()
        with contextlib.suppress(subprocess.CalledProcessError):
            server._ctl("-m", "immediate", "stop")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# --- the jobs database as texbake made it before migrations ----------------------------

# The schema as texbake made it before migrations (its SQLAlchemy metadata's create_all),
# written out: what the first migration must take as it is.
BEFORE_MIGRATIONS = {
    "sqlite": [
        """CREATE TABLE jobs (id VARCHAR(32) NOT NULL, "key" VARCHAR(64) NOT NULL, live_key VARCHAR(64), client VARCHAR(128) NOT NULL,
           state VARCHAR(16) NOT NULL, mesh_name VARCHAR(255) NOT NULL, settings TEXT NOT NULL, progress DOUBLE NOT NULL, error TEXT,
           report TEXT, attempts INTEGER NOT NULL, lease INTEGER NOT NULL, created DATETIME NOT NULL, updated DATETIME NOT NULL,
           heartbeat DATETIME, PRIMARY KEY (id), UNIQUE (live_key))""",
        'CREATE INDEX ix_jobs_key ON jobs ("key")',
        "CREATE INDEX ix_jobs_state ON jobs (state)",
        "CREATE TABLE workers (id VARCHAR(128) NOT NULL, slots INTEGER NOT NULL, seen DATETIME NOT NULL, PRIMARY KEY (id))",
    ],
    "postgresql": [
        """CREATE TABLE jobs (id VARCHAR(32) NOT NULL, key VARCHAR(64) NOT NULL, live_key VARCHAR(64), client VARCHAR(128) NOT NULL,
           state VARCHAR(16) NOT NULL, mesh_name VARCHAR(255) NOT NULL, settings TEXT NOT NULL, progress DOUBLE PRECISION NOT NULL, error TEXT,
           report TEXT, attempts INTEGER NOT NULL, lease INTEGER NOT NULL, created TIMESTAMP WITH TIME ZONE NOT NULL,
           updated TIMESTAMP WITH TIME ZONE NOT NULL, heartbeat TIMESTAMP WITH TIME ZONE, PRIMARY KEY (id), UNIQUE (live_key))""",
        "CREATE INDEX ix_jobs_key ON jobs (key)",
        "CREATE INDEX ix_jobs_state ON jobs (state)",
        "CREATE TABLE workers (id VARCHAR(128) NOT NULL, slots INTEGER NOT NULL, seen TIMESTAMP WITH TIME ZONE NOT NULL, PRIMARY KEY (id))",
    ],
}


def execute(url, *statements, **values):
    """Run SQL as written (datetimes bound as the models bind them, so stored as they were)."""
    from sqlalchemy import DateTime, bindparam, create_engine, text

    engine = create_engine(url)
    try:
        with engine.begin() as conn:
            for statement in statements:
                clause = text(statement)
                dates = [name for name, value in values.items() if isinstance(value, datetime) and f":{name}" in statement]
                conn.execute(clause.bindparams(*(bindparam(name, type_=DateTime(timezone=True)) for name in dates)), values)
    finally:
        engine.dispose()


def old_jobs(n=30):
    """``n`` jobs in every state, as the code before migrations wrote them, of the last
    hour (retention keeps them)."""
    states = ("queued", "running", "done", "failed", "cancelled")
    hour_ago = datetime.now(timezone.utc).replace(microsecond=0) - timedelta(hours=1)
    for i in range(n):
        state = states[i % 5]
        yield {"id": f"{i:032x}", "key": f"k{i}", "live_key": f"k{i}" if state in ("queued", "running", "done") else None,
               "client": f"10.0.0.{i % 3}", "state": state, "mesh_name": f"mesh {i}.ply",
               "settings": json.dumps({"size": 64 + i, "texture": {"name": "wood"}}), "progress": 1.0 if state == "done" else i / n,
               "error": "the bake failed" if state == "failed" else None, "report": json.dumps({"seconds": i}) if state == "done" else None,
               "attempts": i % 3, "lease": i % 4, "created": hour_ago + timedelta(seconds=i),
               "updated": hour_ago + timedelta(seconds=60 + i), "heartbeat": hour_ago if state == "running" else None}


INSERT = ("INSERT INTO jobs (id, key, live_key, client, state, mesh_name, settings, progress, error, report, attempts, lease, created, "
          "updated, heartbeat) VALUES (:id, :key, :live_key, :client, :state, :mesh_name, :settings, :progress, :error, :report, "
          ":attempts, :lease, :created, :updated, :heartbeat)")


def make_old_database(url: str, jobs) -> None:
    """The tables as the code before migrations made them, holding ``jobs`` (see old_jobs)."""
    execute(url, *BEFORE_MIGRATIONS[url.split(":")[0].split("+")[0]])
    for job in jobs:
        execute(url, INSERT, **job)


# --- the service as real processes ------------------------------------------------------

def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(args, data, extra_env=None, port=None):
    env = {**os.environ, "BAKE_DATA_DIR": str(data), "BAKE_HEARTBEAT_SECONDS": "0.5", "BAKE_STALE_SECONDS": "5",
           "BAKE_STOP_SECONDS": "2", **(extra_env or {})}
    log = open(data / f"{args[0]}-{time.monotonic_ns()}.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "texbake.cli", *args], cwd=ROOT, env=env, start_new_session=True, stdout=log, stderr=subprocess.STDOUT)
    proc.log = log
    if port:
        end = time.monotonic() + 60
        while True:
            try:
                httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1)
                break
            except httpx.HTTPError:
                if proc.poll() is not None or time.monotonic() > end:
                    stop(proc)
                    pytest.fail(f"{args[0]} did not start: {open(log.name, errors='replace').read()[-2000:]}")
                time.sleep(0.2)
    return proc


def stop(proc, sig=signal.SIGTERM):
    try:
        os.killpg(proc.pid, sig)
        proc.wait(20)
    except ProcessLookupError:  # the whole group has ended already
        proc.wait()
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    proc.log.close()


def upload(url, path, settings, name=None, headers=None):
    with open(path, "rb") as f:
        return httpx.post(f"{url}/v1/jobs", files={"mesh": (name or path.name, f)}, data={"settings": json.dumps(settings)},
                          headers=headers, timeout=60)


def wait(url, job_id, states=("done", "failed", "cancelled"), timeout=120):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        job = httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).json()
        if job["state"] in states:
            return job
        time.sleep(0.3)
    pytest.fail(f"job {job_id} still {job['state']} after {timeout} s")




class OwnS3:
    """moto's S3 server (``python -m moto.server``) of the test's own on a free port: an
    S3-compatible store on 127.0.0.1, its objects in memory (gone with stop())."""

    KEYS = {"AWS_ACCESS_KEY_ID": "testing", "AWS_SECRET_ACCESS_KEY": "testing", "AWS_REGION": "us-east-1"}

    def __init__(self, folder: Path):
        self.port, self.folder = free_port(), folder
        self.endpoint = f"http://127.0.0.1:{self.port}"
        self.env = {**self.KEYS, "BAKE_S3_ENDPOINT": self.endpoint}  # what the service needs to use it
        self.process: subprocess.Popen | None = None

    def start(self):
        self.log = open(self.folder / "moto.log", "wb")
        self.process = subprocess.Popen([sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p", str(self.port)],
                                        stdout=self.log, stderr=subprocess.STDOUT)
        end = time.monotonic() + 30
        while True:
            try:
                httpx.get(f"{self.endpoint}/moto-api/", timeout=1)
                return self
            except httpx.HTTPError:
                if self.process.poll() is not None or time.monotonic() > end:
                    raise RuntimeError(f"moto's server did not start: {(self.folder / 'moto.log').read_text()[-2000:]}") from None
                time.sleep(0.1)

    def client(self):
        """A boto3 S3 client of the server (moto's own dependency)."""
        import boto3

        return boto3.client("s3", endpoint_url=self.endpoint, region_name="us-east-1",
                            aws_access_key_id="testing", aws_secret_access_key="testing")

    def keys(self, bucket: str, prefix: str = "") -> dict[str, bytes]:
        """Every object under ``prefix``: key -> its bytes."""
        client = self.client()
        found = client.list_objects_v2(Bucket=bucket, Prefix=prefix).get("Contents", [])
        return {o["Key"]: client.get_object(Bucket=bucket, Key=o["Key"])["Body"].read() for o in found}

    def stop(self):
        if self.process is not None:
            self.process.kill()
            self.process.wait()
            self.process = None
            self.log.close()


@pytest.fixture
def own_s3(tmp_path_factory):
    try:
        import moto.server  # noqa: F401
    except ImportError as exc:
        need(f"moto's S3 server needed (pip install -c constraints.txt -e '.[test]'): {exc}")
    server = OwnS3(tmp_path_factory.mktemp("s3")).start()
    yield server
    server.stop()


# the service's in-process tests: the app on a fresh data folder, migrated as `texbake serve`
# migrates it, through FastAPI's TestClient
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
