"""Alembic's entry point: migrates in the connection and transaction that
:func:`texbake.service.core.db.upgrade` hands over (under its lock), or, from Alembic's own
command line, in a connection of its own to the service's database."""

from __future__ import annotations

from alembic import context
from sqlalchemy import Connection, create_engine
from sqlalchemy.pool import NullPool

from texbake.service.core.models import Base


def migrate(connection: Connection) -> None:
    # batch mode: SQLite alters a table by copying it, which autogenerate then writes for us
    context.configure(connection=connection, target_metadata=Base.metadata, render_as_batch=True)
    with context.begin_transaction():  # inside the caller's transaction when it has one
        context.run_migrations()


if context.is_offline_mode():
    raise SystemExit("texbake's migrations look at the database they migrate: run them against one (no --sql)")
handed = context.config.attributes.get("connection")
if handed is not None:
    migrate(handed)
else:
    from texbake.service.core.config import get_settings

    engine = create_engine(context.config.get_main_option("sqlalchemy.url") or get_settings().database, poolclass=NullPool)
    with engine.connect() as connection:
        migrate(connection)
