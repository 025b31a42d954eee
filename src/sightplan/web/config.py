"""Where the server keeps its data and how it may be reached."""

from __future__ import annotations

import ipaddress
import re
import socket
from dataclasses import dataclass
from pathlib import Path

from ..errors import SightplanError

DEFAULT_DATA_DIR = Path("sightplan-data")
DEFAULT_MAX_UPLOAD_MB = 200.0


class ServerConfigError(SightplanError):
    """A server setting that cannot be used (a host it may not bind to, a bad folder or database)."""


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and names that resolve only to them (``localhost``)."""
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        pass
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(host, None)}
    except OSError:
        return False
    return bool(addresses) and all(ipaddress.ip_address(a.split("%")[0]).is_loopback for a in addresses)


@dataclass(frozen=True)
class ServerConfig:
    """data_dir: the server's folder (uploaded files, plan versions, results, the SQLite database);
    database_url: any SQLAlchemy URL, default SQLite in ``data_dir``; max_upload_bytes: the largest upload accepted;
    workers: background jobs run at the same time; team: accounts required (always, on a non-loopback address);
    allowed_origins: origins besides the server's own whose pages may send changes (``https://host`` of a reverse
    proxy that ends TLS in front of the server); basemap_url: the map's background tiles, an XYZ template such as
    ``https://tiles.example.com/{z}/{x}/{y}.png`` (``{-y}`` for TMS rows), fetched by the browser; basemap_attribution:
    the credit its licence asks for, shown on the map; cluster: a dask scheduler's address (``tcp://host:8786``) or
    ``local:N`` (N worker processes started with the server) where evaluations, optimisations and model preparations
    run, None to run them in the server's threads."""

    data_dir: Path = DEFAULT_DATA_DIR
    database_url: str | None = None
    host: str = "127.0.0.1"
    port: int = 8000
    max_upload_bytes: int = int(DEFAULT_MAX_UPLOAD_MB * 1024 * 1024)
    workers: int = 2
    team: bool = False
    allowed_origins: tuple[str, ...] = ()
    basemap_url: str | None = None
    basemap_attribution: str = ""
    cluster: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "data_dir", Path(self.data_dir).expanduser().resolve())
        if self.max_upload_bytes <= 0:
            raise ServerConfigError(f"the upload limit must be positive, got {self.max_upload_bytes} bytes")
        if not self.team and not is_loopback(self.host):
            object.__setattr__(self, "team", True)  # reachable from other machines: accounts are required
        if self.workers < 1:
            raise ServerConfigError(f"at least one worker is needed, got {self.workers}")
        origins = []
        for origin in self.allowed_origins:
            o = origin.strip().rstrip("/").lower()
            if not re.fullmatch(r"https?://[^/\s]+", o):
                raise ServerConfigError(f"an allowed origin is a scheme and a host, like https://sightplan.example.com, "
                                        f"not {origin!r}")
            origins.append(o)
        object.__setattr__(self, "allowed_origins", tuple(origins))
        cluster = (self.cluster or "").strip()
        if cluster and any(c.isspace() for c in cluster):
            raise ServerConfigError(f"a cluster is a dask scheduler's address, like tcp://scheduler:8786, or local:N, "
                                    f"not {self.cluster!r}")
        object.__setattr__(self, "cluster", cluster or None)
        if self.basemap_url is not None:
            url = self.basemap_url.strip()
            if not re.fullmatch(r"https?://[^/\s]+/\S*", url) or not all(
                    k in url for k in ("{z}", "{x}")) or not ("{y}" in url or "{-y}" in url):
                raise ServerConfigError(f"a basemap is an http(s) URL with {{z}}, {{x}} and {{y}} (or {{-y}}) in it, "
                                        f"like https://tiles.example.com/{{z}}/{{x}}/{{y}}.png, not {self.basemap_url!r}")
            object.__setattr__(self, "basemap_url", url)

    @property
    def basemap_origin(self) -> str | None:
        """``scheme://host[:port]`` of the basemap's tiles (the page's security policy lets it fetch from there)."""
        if not self.basemap_url:
            return None
        scheme, _, rest = self.basemap_url.partition("://")
        return f"{scheme.lower()}://{rest.split('/', 1)[0].lower()}"

    @property
    def url(self) -> str:
        return self.database_url or f"sqlite:///{self.data_dir / 'sightplan.db'}"

    @property
    def embedded(self) -> bool:
        """True when the database is the SQLite file in the data folder."""
        return self.database_url is None
