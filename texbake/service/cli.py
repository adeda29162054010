"""The service's commands, ``texbake serve``, ``texbake worker``, ``texbake gc`` and
``texbake db``.

The core's command line finds them through the ``texbake.commands`` entry points, so the
core never imports the service. Both need the ``service`` extra
(``pip install 'texbake[service]'``); without it they say so and exit 2.
"""

from __future__ import annotations

import logging
import sys
from enum import Enum

import typer


def _need_service_extra(exc: ImportError):
    typer.echo(f"texbake: error: this command needs the service extra (pip install 'texbake[service]'): {exc}", err=True)
    raise typer.Exit(2)


def _started(command: str):
    """The service's settings for a long-running ``command``, its logging set up and its
    database migrated (what ``serve`` and ``worker`` do first)."""
    from .core import logs
    from .core.config import get_settings

    settings = get_settings()
    logs.setup(settings.log_format)
    _upgrade_database(command, settings.database)
    return settings


def _upgrade_database(command: str, url: str) -> tuple[str | None, str | None]:
    """Migrate the jobs database (every process that uses it does, as it starts: the lock
    in ``db.upgrade`` lets one at a time); a database out of reach ends the command."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import SQLAlchemyError

    from .core import db

    shown = make_url(url).render_as_string(hide_password=True)
    try:
        before, after = db.upgrade(url)
    except SQLAlchemyError as exc:
        reason = getattr(exc, "orig", None) or exc  # the driver's own words, without SQLAlchemy's SQL and links
        line = (str(reason).strip().splitlines() or [""])[0]
        typer.echo(f"texbake {command}: error: cannot migrate the jobs database {shown}: {type(reason).__name__}: {line}", err=True)
        raise typer.Exit(1) from None
    if before != after:
        logging.getLogger("texbake.service").info("the jobs database %s: migrated from %s to %s", shown, before or "no revision", after)
    return before, after


def serve(
    host: str = typer.Option("127.0.0.1", envvar="BAKE_HOST", help="address to listen on"),
    port: int = typer.Option(8000, envvar="BAKE_PORT", help="port to listen on"),
    workers: int | None = typer.Option(None, help="embedded bake workers (default BAKE_WORKERS, 2; 0: none, API only)"),
):
    """Run the HTTP API with an embedded worker pool (SQLite queue and jobs by default).

    The worker is watched and restarted when it dies; SIGTERM or SIGINT stops the API,
    then the worker (its running bakes finish within BAKE_STOP_SECONDS or go back to the
    queue), and leaves no process behind.
    """
    import signal

    try:
        import uvicorn

        from .main import create_app
        from .worker.supervise import Supervisor, worker_environment
    except ImportError as exc:
        _need_service_extra(exc)

    settings = _started("serve")
    if host not in ("127.0.0.1", "localhost", "::1") and not settings.api_keys:
        print(f"texbake serve: listening on {host} with no API keys: anyone who can reach it can bake (set BAKE_API_KEYS)", file=sys.stderr)
    supervisor = None
    if workers != 0:
        command = [sys.executable, "-m", "texbake.cli", "worker"] + ([] if workers is None else ["--workers", str(workers)])
        supervisor = Supervisor(command, settings.stop_seconds, folder=settings.data_dir.resolve(), env=worker_environment(settings))
        supervisor.start()
    # uvicorn stops on SIGTERM/SIGINT, then raises the signal again with the handlers it
    # found: these, which let this function go on to stop the worker (the default ones
    # would end the process first and leave the worker running).
    app = create_app()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: None)
    try:
        if not _listen(uvicorn, app, host, port):
            raise typer.Exit(1)  # uvicorn said why (the address in use, say)
    finally:
        if supervisor is not None:
            supervisor.stop()


def _listen(uvicorn, app, host: str, port: int) -> bool:
    """Serve ``app`` until stopped, saying on which URL once it listens (the port, for
    ``--port 0``, is the one given to it); False if it never started."""
    import logging

    class Server(uvicorn.Server):
        async def startup(self, sockets=None):
            await super().startup(sockets)
            if self.started:
                bound = self.servers[0].sockets[0].getsockname()[1]
                url = f"http://{f'[{host}]' if ':' in host else host}:{bound}"
                logging.getLogger("texbake.service").info("serving on %s", url, extra={"url": url})

    # log_config=None: uvicorn's loggers go through ours (text or JSON)
    server = Server(uvicorn.Config(app, host=host, port=port, log_level="warning", log_config=None))
    try:
        server.run()
    except KeyboardInterrupt:  # as uvicorn.run: a Ctrl-C during the start
        pass
    return server.started


def worker(workers: int | None = typer.Option(None, help="bakes at a time (default BAKE_WORKERS, 2)")):
    """Run bake workers alone (for more machines: point BAKE_REDIS_URL and BAKE_DATABASE_URL at shared servers).

    On SIGTERM the worker takes no new job, gives running bakes BAKE_STOP_SECONDS to
    finish, then hands the rest back to the queue for another worker; on SIGINT (Ctrl-C)
    it hands them back at once.
    """
    import os
    import threading

    from texbake.workers import PARENT_ENV, die_with_parent

    if os.environ.get(PARENT_ENV):  # started by ``texbake serve``: it must not outlive it
        die_with_parent()
    try:
        from .worker.tasks import hand_back, prestart, queue, reap_forever
    except ImportError as exc:
        _need_service_extra(exc)

    settings = _started("worker")
    count = workers or settings.workers
    prestart(count)  # the first jobs find their bake processes warm
    stop = threading.Event()
    threading.Thread(target=reap_forever, args=(stop, count), daemon=True).start()  # re-queue dead workers' jobs
    try:  # threads are enough: each bake runs in its own child process
        # an idle worker looks for work at least every second (huey's default backs off to 10 s)
        queue().huey.create_consumer(workers=count, worker_type="thread", periodic=True, initial_delay=0.05, max_delay=1.0,
                                     graceful_signal="TERM", shutdown_timeout=settings.stop_seconds).run()
    finally:
        stop.set()
        returned = hand_back()
        if returned:
            logging.getLogger("texbake.service").info("handed %d running jobs back to the queue: %s", len(returned), ", ".join(returned))


def gc():
    """Delete expired jobs (done: BAKE_KEEP_HOURS, failed or cancelled: BAKE_KEEP_FAILED_HOURS)
    with their folders, and left-overs of processes that died; the API does it every 10 minutes."""
    try:
        from .core.config import get_settings
        from .worker.retention import collect
    except ImportError as exc:
        _need_service_extra(exc)
    _upgrade_database("gc", get_settings().database)
    collected = collect(get_settings())
    typer.echo(f"expired {len(collected.jobs)} jobs; removed {len(collected.leftovers)} left-overs")
    for path in collected.leftovers:
        typer.echo(f"  {path}")


class DatabaseAction(str, Enum):
    upgrade = "upgrade"
    current = "current"


def db(action: DatabaseAction = typer.Argument(..., help="upgrade: migrate to the latest schema; current: print the revision")):
    """The jobs database (BAKE_DATABASE_URL, or the data folder's SQLite): migrate it to the
    latest schema, as `serve` and `worker` do when they start, or print its revision."""
    try:
        from sqlalchemy.engine import make_url

        from .core import db as database
        from .core.config import get_settings
    except ImportError as exc:
        _need_service_extra(exc)
    url = get_settings().database
    shown = make_url(url).render_as_string(hide_password=True)
    if action is DatabaseAction.current:
        typer.echo(f"{shown}: at {database.revision(url) or 'no revision (empty, or made before migrations)'}")
        return
    before, after = _upgrade_database("db upgrade", url)
    typer.echo(f"{shown}: at {after} already" if before == after else f"{shown}: upgraded from {before or 'no revision'} to {after}")
