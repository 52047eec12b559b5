"""Engine set-up for SQLite (embedded default) and PostgreSQL, and the migration check.

SQLite: WAL journal and a busy timeout so that the API and several worker processes share one file.
pysqlite's own transaction handling is switched off and we emit ``BEGIN`` ourselves: reads take a
deferred snapshot, while write transactions (``write_tx``) take ``BEGIN IMMEDIATE`` so that they wait on the
busy timeout for the single writer lock instead of failing on a lock upgrade.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import re
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import Connection, Engine, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import DBAPIError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

from foresight.core.errors import CoreError
from foresight.core.limits import printable

MIGRATIONS_DIR = Path(__file__).resolve().parent.parent / "migrations"
_IMMEDIATE = "foresight_immediate"


#: database errors worth another attempt (a dropped connection, a lock held too long)
TRANSIENT_ERRORS: tuple[type[BaseException], ...] = (OperationalError,)
#: every error a database driver raises, as SQLAlchemy wraps it (the API answers a full disk among them with 507)
DatabaseError = DBAPIError


class NotMigratedError(CoreError, RuntimeError):
    """The database schema is not at the latest migration; run `foresight db upgrade`."""


_UNSTORABLE = re.compile(r"\\u(?:0000|d[89a-fA-F])")


def json_serializer(value: Any) -> str:
    """JSON columns' serializer: as ``json.dumps``, except that text no reader can take back is written escaped
    (a NUL as the four characters ``\\x00``, a lone surrogate as ``\\ud800``): PostgreSQL's JSON operators
    refuse ``\\u0000``, and a lone surrogate read back made every listing that held it fail to encode. Requests
    with such text are refused (api.bodies); this keeps any other writer (a worker's result, a stage's message)
    from storing a value that breaks a listing."""
    text = json.dumps(value)
    if _UNSTORABLE.search(text) is None:
        return text
    return json.dumps(printable(value))


_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")


def json_deserializer(text: str | bytes) -> Any:
    """JSON columns' reader: as ``json.loads``, except that values an older version stored and no response can
    carry are read with a replacement, so that no stored row breaks a listing: a lone surrogate as its escape
    (``\\ud800``, the text :func:`json_serializer` now writes), NaN and Infinity as ``None``."""
    if isinstance(text, bytes | bytearray | memoryview):
        text = bytes(text).decode("utf-8", "replace")
    value = json.loads(text, parse_constant=_no_constant)
    return printable(value) if _SURROGATE_ESCAPE.search(text) else value


def _no_constant(_: str) -> None:
    return None


def make_engine(url: str, *, busy_timeout_ms: int = 30000, pool_size: int = 10) -> Engine:
    """An engine for ``url``; SQLite files get their folder created, are created readable by their owner only
    (0600: the file holds every job and token-protected write), and WAL mode is switched on."""
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite":
        # no pre-ping (a round trip per checkout, ~a third of a claim's cost); connections are recycled,
        # and the worker loop and the API survive a dropped connection by retrying / answering 500 once
        return create_engine(
            url,
            pool_size=pool_size,
            max_overflow=2 * pool_size,
            pool_recycle=300,
            json_serializer=json_serializer,
            json_deserializer=json_deserializer,
        )
    if parsed.database and parsed.database != ":memory:":
        path = Path(parsed.database)
        path.parent.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(FileExistsError):
            os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))  # SQLite then keeps its mode
    engine = create_engine(
        url,
        connect_args={"timeout": busy_timeout_ms / 1000, "check_same_thread": False},
        pool_size=pool_size,
        max_overflow=2 * pool_size,
        json_serializer=json_serializer,
        json_deserializer=json_deserializer,
    )

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection, _record):  # noqa: ANN001
        dbapi_connection.isolation_level = None  # we emit BEGIN ourselves (see module docstring)
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute(f"PRAGMA busy_timeout={int(busy_timeout_ms)}")
        cursor.execute("PRAGMA synchronous=NORMAL")  # durable in WAL mode up to the last checkpoint
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn: Connection):
        if conn.get_execution_options().get(_IMMEDIATE, False):
            _begin_immediate(conn.connection.dbapi_connection, busy_timeout_ms)
        else:
            conn.exec_driver_sql("BEGIN")

    return engine


def _begin_immediate(dbapi_connection, busy_timeout_ms: int) -> None:  # noqa: ANN001
    """``BEGIN IMMEDIATE``, waiting for the writer lock in short steps of our own.

    SQLite's busy handler sleeps 1, 2, 5, 10 ... up to 100 ms between attempts; with a few processes
    writing small transactions that turns a sub-millisecond wait into tens of milliseconds (the API's
    p99 latency). Here the wait polls every 0.2–5 ms until the busy timeout.
    """
    deadline = time.monotonic() + busy_timeout_ms / 1000
    delay = 0.0002
    dbapi_connection.execute("PRAGMA busy_timeout=0")
    try:
        while True:
            try:
                dbapi_connection.execute("BEGIN IMMEDIATE")
                return
            except sqlite3.OperationalError as exc:
                if "locked" not in str(exc) and "busy" not in str(exc) or time.monotonic() > deadline:
                    raise
            time.sleep(delay * (0.5 + random.random()))
            delay = min(delay * 1.5, 0.005)
    finally:
        dbapi_connection.execute(f"PRAGMA busy_timeout={int(busy_timeout_ms)}")


def is_sqlite(engine: Engine) -> bool:
    return engine.dialect.name == "sqlite"


_WRITE_LOCKS: dict[int, threading.Lock] = {}


def writer_lock(engine: Engine) -> threading.Lock:
    """The process-local lock that SQLite write transactions of ``engine`` queue on (see :func:`write_tx`)."""
    return _WRITE_LOCKS.setdefault(id(engine.pool), threading.Lock())


@contextmanager
def write_tx(engine: Engine, *, lock_held: bool = False) -> Iterator[Connection]:
    """A write transaction: committed on success, rolled back on error (``BEGIN IMMEDIATE`` on SQLite).

    On SQLite the threads of one process also queue on a process-local lock first: waiting there wakes
    at once when the writer finishes, where SQLite's busy handler sleeps in steps of up to 100 ms, which
    showed as p99 latency spikes with many concurrent API requests.
    """
    if not is_sqlite(engine):
        with engine.begin() as conn:
            yield conn
        return
    lock = contextlib.nullcontext() if lock_held else writer_lock(engine)
    with lock, engine.connect() as conn:
        conn = conn.execution_options(**{_IMMEDIATE: True})
        with conn.begin():
            yield conn


def session_factory(engine: Engine, *, write: bool = False) -> sessionmaker[Session]:
    """ORM sessions; ``write`` sessions take ``BEGIN IMMEDIATE`` on SQLite (a read-then-write transaction
    would otherwise fail at once with "database is locked" when another process wrote since its read)."""
    if write and is_sqlite(engine):
        engine = engine.execution_options(**{_IMMEDIATE: True})
    return sessionmaker(engine, expire_on_commit=False)


def head_revision() -> str:
    from alembic.script import ScriptDirectory

    return ScriptDirectory(str(MIGRATIONS_DIR)).get_current_head()


def current_revision(engine: Engine) -> str | None:
    try:
        conn = engine.connect()
    except OperationalError as exc:
        url = engine.url.render_as_string(hide_password=True)
        raise CoreError(
            f"cannot connect to database {url}: {str(exc.orig).strip().splitlines()[0]}"
        ) from None
    with conn:
        try:
            row = conn.execute(text("SELECT version_num FROM alembic_version")).first()
        except Exception:  # the table is missing: never migrated
            return None
    return row[0] if row else None


def check_migrated(engine: Engine) -> str:
    """The schema revision, or :class:`NotMigratedError` when the database is not at head."""
    current, head = current_revision(engine), head_revision()
    if current != head:
        url = engine.url.render_as_string(hide_password=True)
        raise NotMigratedError(
            f"database {url} is at revision {current or 'none (empty)'}, expected {head}: "
            "run `foresight db upgrade` first"
        )
    return current


def upgrade(url: str, revision: str = "head") -> None:
    """Migrate the database at ``url`` (``alembic upgrade``)."""
    from alembic import command
    from alembic.config import Config

    make_engine(url).dispose()  # creates a SQLite file's folder
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    command.upgrade(cfg, revision)
