"""The database: an engine for any SQLAlchemy URL, sessions, and the schema brought up to date by Alembic."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session, sessionmaker

from .config import ServerConfigError

MIGRATIONS = Path(__file__).with_name("migrations")


def driver_url(url: str) -> str:
    """``postgresql://…`` (and ``postgres://…``) through psycopg 3, the driver sightplan installs, unless the URL
    names a driver itself."""
    for scheme in ("postgresql://", "postgres://"):
        if url.startswith(scheme):
            return "postgresql+psycopg://" + url[len(scheme):]
    return url


def make_engine(url: str) -> Engine:
    """An engine for ``url``. SQLite gets foreign keys on, a busy timeout and WAL, so the worker threads and the
    requests can share it."""
    url = driver_url(url)
    try:
        if url.startswith("sqlite"):
            engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30})

            @event.listens_for(engine, "connect")
            def _sqlite_pragmas(dbapi_connection, _record) -> None:  # pragma: no cover - trivial
                cursor = dbapi_connection.cursor()
                cursor.execute("PRAGMA foreign_keys=ON")
                cursor.execute("PRAGMA journal_mode=WAL")
                cursor.close()

            return engine
        return create_engine(url, pool_pre_ping=True)
    except (SQLAlchemyError, ImportError, ValueError) as exc:
        raise ServerConfigError(f"cannot use the database {url!r}: {exc}") from None


def upgrade_database(engine: Engine) -> None:
    """Apply every Alembic migration the database lacks (the environment ships inside the package)."""
    from alembic import command
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    try:
        with engine.begin() as connection:
            config.attributes["connection"] = connection
            command.upgrade(config, "head")
    except SQLAlchemyError as exc:
        raise ServerConfigError(f"cannot set up the database {engine.url.render_as_string(hide_password=True)}: "
                                f"{exc.__class__.__name__}: {exc.orig if hasattr(exc, 'orig') else exc}") from None


class Database:
    """The engine and a session factory."""

    def __init__(self, url: str) -> None:
        self.engine = make_engine(url)
        self.sessions = sessionmaker(self.engine, expire_on_commit=False)

    @contextmanager
    def session(self) -> Iterator[Session]:
        """A session committed at the end of the block, rolled back on an error."""
        with self.sessions() as s:
            try:
                yield s
                s.commit()
            except BaseException:
                s.rollback()
                raise

    def dispose(self) -> None:
        self.engine.dispose()
