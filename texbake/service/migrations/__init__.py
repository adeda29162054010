"""The jobs database's migrations (Alembic): ``env.py`` and ``versions/``; run by
:func:`texbake.service.core.db.upgrade`."""
