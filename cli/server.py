"""Server-side commands: `foresight up`, `serve`, `worker`, `db upgrade`, `store gc`."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import subprocess
import sys
from pathlib import Path

from foresight.store.settings import Settings


def register(sub: argparse._SubParsersAction) -> None:
    up = sub.add_parser("up", help="migrate the database, then run the API server and a worker")
    _server_args(up)
    up.add_argument("--concurrency", type=int, default=1, help="worker job slots (default 1)")
    up.set_defaults(func=cmd_up)

    serve = sub.add_parser("serve", help="run the API server (the database must be migrated)")
    _server_args(serve)
    serve.set_defaults(func=cmd_serve)

    worker = sub.add_parser("worker", help="run a job worker (the database must be migrated)")
    worker.add_argument("--concurrency", type=int, default=1, help="jobs run at once (threads; default 1)")
    worker.add_argument("--kinds", help="comma-separated job kinds to take (default: all)")
    worker.set_defaults(func=cmd_worker)

    db = sub.add_parser("db", help="database administration").add_subparsers(dest="action", required=True)
    upgrade = db.add_parser("upgrade", help="migrate the database to the latest schema")
    upgrade.add_argument("--revision", default="head", help="Alembic revision to migrate to (default head)")
    upgrade.set_defaults(func=cmd_db_upgrade)

    store = sub.add_parser("store", help="artifact store administration").add_subparsers(
        dest="action", required=True
    )
    gc = store.add_parser(
        "gc", help="remove files no job, bundle, model or dataset accounts for (crashes, full disks)"
    )
    gc.add_argument("--dry-run", action="store_true", help="only list what would be removed")
    gc.add_argument("--json", action="store_true", help="print the report as JSON")
    gc.set_defaults(func=cmd_store_gc)


def _server_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1; 0.0.0.0 for every interface)",
    )
    parser.add_argument("--port", type=int, default=8000, help="TCP port to listen on (default 8000)")
    parser.add_argument(
        "--workers", type=int, default=1, help="server processes (uvicorn workers; default 1)"
    )
    parser.add_argument(
        "--log-level",
        default="warning",
        choices=["critical", "error", "warning", "info", "debug"],
        help="server log level (default warning)",
    )


def _logging(level: str = "info") -> None:
    logging.basicConfig(level=level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logging.getLogger("alembic").setLevel(logging.WARNING)  # its plugin set-up lines on every schema check


def cmd_db_upgrade(args: argparse.Namespace) -> int:
    from foresight.store.session import upgrade

    settings = Settings()
    upgrade(settings.resolved_database_url, args.revision)
    print(f"database {settings.resolved_database_url} at {args.revision}", file=sys.stderr)
    return 0


def cmd_store_gc(args: argparse.Namespace) -> int:
    import dataclasses
    import json

    from foresight.store.gc import collect_garbage
    from foresight.store.session import make_engine

    settings = Settings()
    engine = make_engine(settings.resolved_database_url)
    try:
        report = collect_garbage(engine, settings.store_root, dry_run=args.dry_run)
    finally:
        engine.dispose()
    if args.json:
        print(json.dumps({**dataclasses.asdict(report), "dry_run": args.dry_run}))
    else:
        for path in report.paths:
            print(path)
        verb = "would free" if args.dry_run else "freed"
        print(
            f"{len(report.paths)} orphans; {verb} {report.bytes} bytes under {settings.store_root}",
            file=sys.stderr,
        )
    return 0


def _serve(settings: Settings, args: argparse.Namespace) -> None:
    import uvicorn

    from foresight.api.main import create_server_app

    app = create_server_app(settings)  # fails here, before serving, on an un-migrated database
    print(f"foresight API on http://{args.host}:{args.port} (store {settings.store_root})", file=sys.stderr)
    # uvicorn shuts down gracefully on SIGTERM/SIGINT, then re-raises the signal to the handler that was
    # installed before it: make that one return, so that callers' clean-up runs and the exit code is 0.
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: None)
    if args.workers > 1:  # each process builds its app from the same FORESIGHT_* environment
        uvicorn.run(
            "foresight.api.main:create_server_app",
            factory=True,
            workers=args.workers,
            host=args.host,
            port=args.port,
            log_level=args.log_level,
            access_log=False,
        )
    else:
        uvicorn.run(app, host=args.host, port=args.port, log_level=args.log_level, access_log=False)


def cmd_serve(args: argparse.Namespace) -> int:
    _logging(args.log_level)
    _serve(Settings(), args)
    return 0


def cmd_worker(args: argparse.Namespace) -> int:
    from foresight.store import queue
    from foresight.store.session import check_migrated, make_engine
    from foresight.worker.memory import limit_memory
    from foresight.worker.runner import JobWorker

    _logging()
    settings = Settings()
    memory_mb = limit_memory(settings)
    engine = make_engine(settings.resolved_database_url, busy_timeout_ms=settings.sqlite_busy_timeout_ms)
    check_migrated(engine)
    kinds = [k.strip() for k in args.kinds.split(",")] if args.kinds else None
    worker = JobWorker(settings, engine, concurrency=max(1, args.concurrency), kinds=kinds)
    queue.prune_workers(engine)  # forget workers silent for a day
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: worker.stop())
    memory = f"{memory_mb} MiB" if memory_mb else "no limit"
    print(
        f"foresight worker {worker.id}: {args.concurrency} slot(s), kinds {worker.kinds}, memory {memory}",
        file=sys.stderr,
    )
    worker.run()
    return 0


UP_WORKER_NICE = (
    5  #: how much lower the CPU priority of the worker `foresight up` starts is than the server's
)


def cmd_up(args: argparse.Namespace) -> int:
    """Migrate, start a worker process, serve in this one; stopping the server stops the worker.

    While it runs, ``<data dir>/server.json`` says where (URL and pid): a CLI client in any folder finds the server
    and its token through the per-user data dir, whatever the port."""
    import json

    from foresight.store.session import upgrade
    from foresight.worker.mlflow_export import settings_target

    settings = Settings()
    _refuse_second_server(settings, args.host, args.port)  # before anything is printed or written
    settings_target(settings)  # an MLflow tracking URI that cannot work stops here, not in the worker
    _logging(args.log_level)
    upgrade(settings.resolved_database_url)
    settings.server_token()  # create the data dir's token before the client needs it
    host = "127.0.0.1" if args.host in ("0.0.0.0", "::", "") else args.host
    url = f"http://{host}:{args.port}"
    data = settings.data_dir.resolve()
    token = "$FORESIGHT_API_TOKEN" if settings.api_token else str(settings.token_file().resolve())
    print(
        f"foresight up: dashboard {url}/ui\n  data folder  {data}\n  write token  {token}\n"
        f"  clients in any folder use both (FORESIGHT_DATA_DIR={data} for another user or data folder)",
        file=sys.stderr,
        flush=True,
    )
    server_file = settings.server_file()
    server_file.parent.mkdir(parents=True, exist_ok=True)
    server_file.write_text(json.dumps({"url": url, "pid": os.getpid()}) + "\n")
    # The worker runs at a lower CPU priority than the server: its episodes are batch work, the server's
    # requests are waited on. On a machine where both share the cores, status reads during a running job
    # otherwise queue behind the episodes (bench/api_load.py --phases status_reads_busy).
    worker = subprocess.Popen(
        [sys.executable, "-m", "foresight.cli.main", "worker", "--concurrency", str(args.concurrency)],
        env=os.environ.copy(),
        preexec_fn=lambda: os.nice(UP_WORKER_NICE),  # noqa: PLW1509 (before the server starts any thread)
    )
    try:
        _serve(settings, args)
    finally:
        worker.send_signal(signal.SIGTERM)
        try:
            worker.wait(timeout=settings.shutdown_grace_s + 10)
        except subprocess.TimeoutExpired:
            worker.kill()
        _forget(server_file)
    return 0


def _refuse_second_server(settings: Settings, host: str, port: int) -> None:
    """CoreError when a live `foresight up` already serves this data folder (its ``server.json`` names a running
    process) or the port is taken: a second server would overwrite, then delete, the first one's file."""
    import json
    import socket

    from foresight.core.errors import CoreError

    server_file = settings.server_file()
    try:
        running = json.loads(server_file.read_text())
        pid = int(running["pid"])
        os.kill(pid, 0)
    except (OSError, ValueError, KeyError, TypeError):
        pass  # no file, or the process that wrote it is gone
    else:
        if pid != os.getpid():
            raise CoreError(
                f"a foresight server already runs for data folder {settings.data_dir.resolve()} at "
                f"{running.get('url')} (pid {pid}); stop it first, or set FORESIGHT_DATA_DIR to "
                "another folder"
            )
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn binds
        try:
            probe.bind((host, port))
        except OSError as exc:
            raise CoreError(
                f"cannot serve on {host}:{port}: {exc.strerror} (another server uses it? pick another --port)"
            ) from None


def _forget(server_file: Path) -> None:
    """Remove ``server.json`` if it is still this process's (another `up` may have started on the data dir since)."""
    import json

    try:
        if json.loads(server_file.read_text()).get("pid") == os.getpid():
            server_file.unlink()
    except (OSError, ValueError, AttributeError):
        pass
