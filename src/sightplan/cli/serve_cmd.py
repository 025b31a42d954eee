"""``sightplan serve``: the web server and its REST API; ``sightplan users``: the accounts of a team server."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer

from ..extras import require
from .base import app, console
from .errors import friendly_errors

GRACEFUL_SHUTDOWN_S = 4  # open connections (progress streams) after SIGTERM, before the jobs are stopped

DataOpt = Annotated[Path, typer.Option(help="Data folder: uploaded models, plan versions, results and the embedded "
                                            "SQLite database; created on first start")]
DatabaseOpt = Annotated[str | None, typer.Option(
    help="SQLAlchemy database URL (e.g. postgresql://user@host/db); default: SQLite in the data folder")]


@app.command("serve")
@friendly_errors
def serve_command(
    data: DataOpt = Path("sightplan-data"),
    host: Annotated[str, typer.Option(help="Address to listen on; any but the loopback address means team mode")]
    = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to listen on")] = 8000,
    database: DatabaseOpt = None,
    max_upload_mb: Annotated[float, typer.Option(help="Largest upload accepted (MB)")] = 200.0,
    workers: Annotated[int, typer.Option(help="Background jobs (model loads, evaluations) run at the same time")] = 2,
    team: Annotated[bool, typer.Option("--team", help="Require accounts (made with 'sightplan users add') even on "
                                                      "the loopback address")] = False,
    sample: Annotated[bool, typer.Option("--sample", help="Start with the sample project: the bundled Duplex, a facade "
                                                          "grid around it and its evaluation (once per data folder)")]
    = False,
    allowed_origin: Annotated[list[str] | None, typer.Option(
        "--allowed-origin", help="An origin besides the server's own whose pages may send changes, e.g. the "
                                 "https://host of a reverse proxy in front of it (repeatable)")] = None,
    basemap: Annotated[str | None, typer.Option(
        envvar="SIGHTPLAN_BASEMAP", help="The map's background: an XYZ tile URL with {z}, {x} and {y} (or {-y}), "
                                         "fetched by the browser; default: a plain grid")] = None,
    basemap_attribution: Annotated[str, typer.Option(
        envvar="SIGHTPLAN_BASEMAP_ATTRIBUTION", help="The credit the basemap's licence asks for, shown on the map")]
    = "",
    cluster: Annotated[str | None, typer.Option(
        envvar="SIGHTPLAN_CLUSTER", help="Run evaluations, optimisations and model preparation on a dask cluster: a "
                                         "scheduler address (tcp://host:8786) or local:N for N local worker "
                                         "processes; its workers need the data folder at the same path")] = None,
) -> None:
    """Serve the web application and its REST API (OpenAPI docs at /docs).

    On the loopback address it runs for you alone, with no login. With --team, or on any other address, every request
    needs an account, and each project is visible to its members only."""
    require("web", "sightplan serve")
    import uvicorn

    from ..assets import AssetsMissing, check_assets
    from ..errors import SightplanError

    try:
        check_assets()
    except AssetsMissing as exc:  # one line, before the server starts: a page without its scripts is no page
        raise SightplanError(str(exc)) from None

    from ..web.app import create_app
    from ..web.config import ServerConfig

    config = ServerConfig(data_dir=data, database_url=database, host=host, port=port,
                          max_upload_bytes=int(max_upload_mb * 1024 * 1024), workers=workers, team=team,
                          allowed_origins=tuple(allowed_origin or ()), basemap_url=basemap,
                          basemap_attribution=basemap_attribution, cluster=cluster)
    if config.cluster is not None:
        require("cluster", "sightplan serve --cluster")
    web_app = create_app(config)
    if config.cluster is not None:
        _cluster_line(web_app.state.sightplan)
    if sample:
        _sample_project(web_app.state.sightplan, config.team)
    where = "embedded SQLite in the data folder" if config.embedded else f"database {database}"
    if config.team:
        users = _user_count(web_app.state.sightplan.db)
        console.print(f"sightplan serve: team mode — every request needs an account; {users} account(s). "
                      f"Data in {config.data_dir} ({where}).", highlight=False)
        if users == 0:
            console.print(f"[yellow]no accounts yet:[/] create one with 'sightplan users add NAME --data {data}'",
                          highlight=False)
    else:
        console.print(f"sightplan serve: single-user mode, no login — for you on this machine only (loopback {host}). "
                      f"Data in {config.data_dir} ({where}).", highlight=False)
    console.print(f"Open http://{host}:{port}/ in a browser (API docs at http://{host}:{port}/docs)", highlight=False)
    # open progress streams get a few seconds, then the jobs their grace period: SIGTERM stops it within 10 s
    uvicorn.run(web_app, host=host, port=port, log_level="info", timeout_graceful_shutdown=GRACEFUL_SHUTDOWN_S)


def _cluster_line(state) -> None:
    """Where the jobs go, and the workers that would fail a model's preparation for not seeing the data folder."""
    cluster = state.cluster
    console.print(f"Jobs run on the dask cluster at {cluster.address} ({cluster.workers()} worker(s) now).",
                  highlight=False)
    missing = cluster.workers_without(state.config.data_dir)
    if missing:
        console.print(f"[yellow]{len(missing)} worker(s) do not see the data folder {state.config.data_dir}[/] "
                      f"({', '.join(missing[:3])}{', …' if len(missing) > 3 else ''}): models prepared there fail; "
                      "mount it at the same path on every worker", highlight=False)


def _sample_project(state, team: bool) -> None:
    from ..web.sample import SAMPLE_PROJECT, ensure_sample_project

    if team:
        console.print("[yellow]--sample is for single-user mode:[/] in team mode every project needs an owner",
                      highlight=False)
        return
    with console.status("preparing the sample project (the bundled Duplex and a facade grid)…"):
        job = ensure_sample_project(state)
    if job is None:
        console.print(f"sample project '{SAMPLE_PROJECT}': already in the data folder", highlight=False)
    else:
        console.print(f"sample project '{SAMPLE_PROJECT}': model and plan ready, its evaluation running (job {job})",
                      highlight=False)


def _user_count(db) -> int:
    from sqlalchemy import func, select

    from ..web.models import User

    with db.session() as s:
        return int(s.scalar(select(func.count()).select_from(User)) or 0)


users_app = typer.Typer(no_args_is_help=True, help="Accounts of a team server (sightplan serve --team).")
app.add_typer(users_app, name="users")


@contextmanager
def _accounts(data: Path, database: str | None):
    """A session on the server's database (brought up to date first), committed at the end."""
    require("web", "sightplan users")
    from ..web.config import ServerConfig
    from ..web.db import Database, upgrade_database

    config = ServerConfig(data_dir=data, database_url=database)
    config.data_dir.mkdir(parents=True, exist_ok=True)
    db = Database(config.url)
    try:
        upgrade_database(db.engine)
        with db.session() as s:
            yield s
    finally:
        db.dispose()


def _user(s, username: str):
    from ..web.auth import AccountError, find_user

    user = find_user(s, username)
    if user is None:
        raise AccountError(f"no user {username!r}")
    return user


def _password(password_stdin: bool) -> str:
    if password_stdin:
        return sys.stdin.readline().rstrip("\r\n")
    return typer.prompt("Password", hide_input=True, confirmation_prompt=True)


@users_app.command("add")
@friendly_errors
def users_add(
    username: Annotated[str, typer.Argument(help="The new account's user name")],
    data: DataOpt = Path("sightplan-data"),
    database: DatabaseOpt = None,
    password_stdin: Annotated[bool, typer.Option("--password-stdin", help="Read the password from the first line "
                                                                          "of standard input")] = False,
) -> None:
    """Create an account (the password is asked twice, or read from stdin)."""
    from ..web.auth import create_user

    password = _password(password_stdin)
    with _accounts(data, database) as s:
        create_user(s, username, password)
    console.print(f"account {username} created", highlight=False)


@users_app.command("passwd")
@friendly_errors
def users_passwd(
    username: Annotated[str, typer.Argument(help="The account")],
    data: DataOpt = Path("sightplan-data"),
    database: DatabaseOpt = None,
    password_stdin: Annotated[bool, typer.Option("--password-stdin", help="Read the password from stdin")] = False,
) -> None:
    """Set an account's password; its login sessions end."""
    from ..web.auth import set_password

    password = _password(password_stdin)
    with _accounts(data, database) as s:
        set_password(s, _user(s, username), password)
    console.print(f"password of {username} changed", highlight=False)


@users_app.command("list")
@friendly_errors
def users_list(data: DataOpt = Path("sightplan-data"), database: DatabaseOpt = None) -> None:
    """The accounts and their projects."""
    from sqlalchemy import select

    from ..web.models import Membership, User

    with _accounts(data, database) as s:
        for user in s.scalars(select(User).order_by(User.username)):
            roles = s.execute(select(Membership.project_id, Membership.role)
                              .where(Membership.user_id == user.id).order_by(Membership.project_id))
            text = ", ".join(f"project {pid} {role}" for pid, role in roles) or "no projects"
            console.print(f"{user.username}: {text}", highlight=False)


def _sole_owner_of(s, user_id: int) -> list[int]:
    from sqlalchemy import func, select

    from ..web.models import Membership

    owned = s.scalars(select(Membership.project_id).where(Membership.user_id == user_id, Membership.role == "owner"))
    return [pid for pid in owned
            if s.scalar(select(func.count()).select_from(Membership).where(Membership.project_id == pid,
                                                                           Membership.role == "owner")) == 1]


@users_app.command("remove")
@friendly_errors
def users_remove(username: Annotated[str, typer.Argument(help="The account")],
                 data: DataOpt = Path("sightplan-data"), database: DatabaseOpt = None) -> None:
    """Delete an account with its sessions, tokens and memberships (its projects stay with their other members)."""
    from ..web.auth import AccountError

    with _accounts(data, database) as s:
        user = _user(s, username)
        sole = _sole_owner_of(s, user.id)
        if sole:
            raise AccountError(f"{username} is the only owner of project(s) {', '.join(map(str, sole))}: make "
                               "another member owner first")
        s.delete(user)
    console.print(f"account {username} removed", highlight=False)


