"""The jobs database: its engine and sessions, made from the service's settings, and its
migrations (Alembic, ``texbake/service/migrations``).

SQLite in the data folder by default, PostgreSQL (or any SQLAlchemy URL) when
``BAKE_DATABASE_URL`` is set. The tables are in :mod:`.models`, every query in
:mod:`.crud`.

Waiting is bounded: a session waits at most ``BAKE_DATABASE_WAIT_SECONDS`` for a pooled
connection (then ``sqlalchemy.exc.TimeoutError``) and as long for a lock (SQLite's write
lock: "database is locked"; PostgreSQL's ``lock_timeout``: ``LockNotAvailable``, both
``OperationalError``); the API answers each with a 503 and ``Retry-After``.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache

from sqlalchemy import Connection, create_engine, event, func, select, text
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.orm import Session, sessionmaker
from sqlalchemy.pool import NullPool

from .config import get_settings

MIGRATION_WAIT_SECONDS = 120.0  # a process that starts while another migrates waits this long for it


@lru_cache
def sessions(url: str) -> sessionmaker[Session]:
    """The session factory of the database at ``url`` (one engine, one pool a process).

    The schema is not made here: :func:`upgrade` makes and migrates it (``texbake
    serve`` and ``texbake worker`` run it as they start, ``texbake db upgrade`` alone).
    """
    wait = get_settings().database_wait_seconds
    parsed = make_url(url)
    connect_args = {}
    if parsed.get_backend_name() == "postgresql" and "options" not in parsed.query:
        connect_args["options"] = f"-c lock_timeout={int(wait * 1000)}"  # a row or advisory lock waited for: as bounded
    engine = create_engine(url, pool_pre_ping=True, pool_timeout=wait, connect_args=connect_args)
    if parsed.get_backend_name() == "sqlite":
        _sqlite_waits(engine, wait)
    return sessionmaker(engine, expire_on_commit=False)


def _sqlite_waits(engine: Engine, seconds: float) -> None:
    @event.listens_for(engine, "connect")
    def _sqlite(conn, _):  # many readers, one writer, waiting a bounded time rather than failing at once
        conn.execute(f"PRAGMA busy_timeout={int(seconds * 1000)}")  # first: switching to WAL may wait for a lock
        conn.execute("PRAGMA journal_mode=WAL")


def lock_id(name: str) -> int:
    """A PostgreSQL advisory lock's key for ``name`` (a signed 64-bit integer)."""
    return int.from_bytes(hashlib.sha256(f"texbake:{name}".encode()).digest()[:8], "big", signed=True)


def write_lock(conn: Session | Connection, name: str) -> None:
    """Take the lock ``name`` until the end of the current transaction, which must not have
    run a statement yet: writers that check and then write (the per-client limit, the
    migrations) take it first, so that what they checked still holds when they write.

    PostgreSQL: an advisory transaction lock of that name (other names run on). SQLite:
    the database's write lock (``BEGIN IMMEDIATE``), whatever the name: SQLite has one
    writer at a time anyway. Other databases: no lock.
    """
    dialect = conn.get_bind().dialect.name if isinstance(conn, Session) else conn.dialect.name
    if dialect == "sqlite":
        conn.execute(text("BEGIN IMMEDIATE"))
    elif dialect == "postgresql":
        conn.execute(select(func.pg_advisory_xact_lock(lock_id(name))))


def migrations_config():
    """Alembic's configuration of the migrations shipped in the package."""
    from pathlib import Path

    from alembic.config import Config

    folder = Path(__file__).resolve().parent.parent / "migrations"
    config = Config(str(folder / "alembic.ini"))
    config.set_main_option("script_location", str(folder))
    return config


def revision(url: str) -> str | None:
    """The migration the database at ``url`` is at (None: none, or made before migrations)."""
    from alembic.runtime.migration import MigrationContext

    engine = create_engine(url, poolclass=NullPool)
    try:
        with engine.connect() as conn:
            return MigrationContext.configure(conn).get_current_revision()
    finally:
        engine.dispose()


def upgrade(url: str, target: str = "head") -> tuple[str | None, str | None]:
    """Bring the database at ``url`` to the migration ``target``; returns the revisions
    before and after. A database made before migrations (its tables, no
    ``alembic_version``) is taken as it is by the first migration.

    One transaction under the ``migrations`` lock: processes that start together (the
    API and its workers) migrate one at a time, and the later ones find nothing to do.
    """
    from alembic import command
    from alembic.runtime.migration import MigrationContext

    engine = create_engine(url, poolclass=NullPool)
    if engine.dialect.name == "sqlite":
        _sqlite_waits(engine, MIGRATION_WAIT_SECONDS)  # the lock below waits for another process's migration
    try:
        with engine.connect() as conn:
            if conn.dialect.name == "postgresql":
                conn.exec_driver_sql(f"SET lock_timeout = '{int(MIGRATION_WAIT_SECONDS * 1000)}ms'")
                conn.commit()  # a setting of the connection, kept past its transaction
            write_lock(conn, "migrations")
            before = MigrationContext.configure(conn).get_current_revision()
            config = migrations_config()
            config.attributes["connection"] = conn  # env.py migrates in this transaction
            command.upgrade(config, target)
            after = MigrationContext.configure(conn).get_current_revision()
            conn.commit()
    finally:
        engine.dispose()
    return before, after
