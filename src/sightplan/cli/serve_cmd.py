"""``sightplan serve``: the web server and its REST API."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .errors import friendly_errors
from .main import app, console


@app.command("serve")
@friendly_errors
def serve_command(
    data: Annotated[Path, typer.Option(help="Data folder: uploaded models, plan versions, results and the embedded "
                                            "SQLite database; created on first start")] = Path("sightplan-data"),
    host: Annotated[str, typer.Option(help="Address to listen on: the loopback address only, until accounts exist")]
    = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to listen on")] = 8000,
    database: Annotated[str | None, typer.Option(
        help="SQLAlchemy database URL (e.g. postgresql://user@host/db); default: SQLite in the data folder")] = None,
    max_upload_mb: Annotated[float, typer.Option(help="Largest upload accepted (MB)")] = 200.0,
    workers: Annotated[int, typer.Option(help="Background jobs (model loads, evaluations) run at the same time")] = 2,
) -> None:
    """Serve the REST API (OpenAPI docs at /docs) for one user on this machine, with no login."""
    import uvicorn

    from ..web.app import create_app
    from ..web.config import ServerConfig, check_host

    check_host(host)
    config = ServerConfig(data_dir=data, database_url=database, host=host, port=port,
                          max_upload_bytes=int(max_upload_mb * 1024 * 1024), workers=workers)
    web_app = create_app(config)
    where = "embedded SQLite in the data folder" if config.embedded else f"database {database}"
    console.print(f"sightplan serve: single-user mode, no login — for you on this machine only (loopback {host}). "
                  f"Data in {config.data_dir} ({where}).", highlight=False)
    console.print(f"API at http://{host}:{port}/api, docs at http://{host}:{port}/docs", highlight=False)
    uvicorn.run(web_app, host=host, port=port, log_level="info")
