"""The jobs and workers tables, as texbake made them before it had migrations.

A database made then is taken as it is: its tables are kept (stamped at this revision),
and a jobs table older than the ``lease`` and ``live_key`` columns gets them, each key's
newest live job holding its key (older duplicates, from before the unique key, hold none).
Table and state names are written out here: a migration stays as it was written when the
models change.

Revision ID: 0001
Revises:
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None

LIVE = "('queued', 'running', 'done')"  # the states that hold a job's key


def upgrade() -> None:
    tables = set(sa.inspect(op.get_bind()).get_table_names())
    if "jobs" in tables:
        _adopt_jobs()
    else:
        _create_jobs()
    if "workers" not in tables:
        op.create_table(
            "workers",
            sa.Column("id", sa.String(128), primary_key=True),
            sa.Column("slots", sa.Integer(), nullable=False),
            sa.Column("seen", sa.DateTime(timezone=True), nullable=False),
        )


def _create_jobs() -> None:
    op.create_table(
        "jobs",
        sa.Column("id", sa.String(32), primary_key=True),
        sa.Column("key", sa.String(64), nullable=False),
        sa.Column("live_key", sa.String(64), nullable=True),
        sa.Column("client", sa.String(128), nullable=False),
        sa.Column("state", sa.String(16), nullable=False),
        sa.Column("mesh_name", sa.String(255), nullable=False),
        sa.Column("settings", sa.Text(), nullable=False),
        sa.Column("progress", sa.Double(), nullable=False),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("report", sa.Text(), nullable=True),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("lease", sa.Integer(), nullable=False),
        sa.Column("created", sa.DateTime(timezone=True), nullable=False),
        sa.Column("updated", sa.DateTime(timezone=True), nullable=False),
        sa.Column("heartbeat", sa.DateTime(timezone=True), nullable=True),
        sa.UniqueConstraint("live_key"),
    )
    op.create_index("ix_jobs_key", "jobs", ["key"])
    op.create_index("ix_jobs_state", "jobs", ["state"])


def _adopt_jobs() -> None:
    columns = {c["name"] for c in sa.inspect(op.get_bind()).get_columns("jobs")}
    if "lease" not in columns:
        op.add_column("jobs", sa.Column("lease", sa.Integer(), nullable=False, server_default="0"))
    if "live_key" not in columns:
        op.add_column("jobs", sa.Column("live_key", sa.String(64), nullable=True))
        op.execute(f"UPDATE jobs SET live_key = key WHERE state IN {LIVE} AND id = "
                   f"(SELECT j.id FROM jobs j WHERE j.key = jobs.key AND j.state IN {LIVE} ORDER BY j.created DESC LIMIT 1)")
        op.create_index("ix_jobs_live_key", "jobs", ["live_key"], unique=True)


def downgrade() -> None:
    op.drop_table("workers")
    op.drop_table("jobs")
