"""The JavaScript the page, /docs and the HTML reports load from npm packages, and where it is.

In a checkout the packages are in ``web/node_modules`` (``npm ci --prefix web``, from the pinned
``web/package-lock.json``). A wheel carries them itself: building it copies into ``sightplan/web/vendor/`` only the
files the page can load, found by following the imports from the page's own modules through its import map
(:func:`served_files`), with each package's licence and ``package.json``.

This module reads nothing but the standard library: the wheel's build loads it by its path, before any of
sightplan's dependencies are installed.
"""

from __future__ import annotations

import json
import posixpath
import re
import shutil
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
STATIC_DIR = PACKAGE_DIR / "web" / "static"
PACKAGED = PACKAGE_DIR / "web" / "vendor"  # in an installed wheel
CHECKOUT = PACKAGE_DIR.parents[1] / "web" / "node_modules"  # in a checkout
REPORT_VIEWER = PACKAGE_DIR / "report" / "viewer.js"

#: The packages served under /vendor/<package>/.
PACKAGES = ("three", "three-mesh-bvh", "3d-tiles-renderer", "swagger-ui-dist", "maplibre-gl")
#: Files loaded by URL rather than imported: stylesheets, workers, Swagger UI's bundle.
LOADED_BY_URL = ("maplibre-gl/dist/maplibre-gl.css", "maplibre-gl/dist/maplibre-gl-worker.mjs",
                 "swagger-ui-dist/swagger-ui.css", "swagger-ui-dist/swagger-ui-bundle.js")
#: The modules the HTML report imports (report/html.py inlines them from the three package).
REPORT_ENTRIES = ("three/build/three.module.js", "three/examples/jsm/controls/OrbitControls.js",
                  "three/examples/jsm/loaders/GLTFLoader.js")
KEEP = ("package.json", "LICENSE", "LICENSE.md", "LICENSE.txt", "license", "LICENCE")

# import … from 'x', export … from 'x', import 'x', import('x')
_SPECIFIER = re.compile(r"""(?:\bfrom\s*|\bimport\s*\(?\s*)(['"])([^'"\n]{1,300})\1""")
_IMPORT_MAP = re.compile(r"""<script type="importmap">\s*(\{.*?\})\s*</script>""", re.S)


class AssetsMissing(RuntimeError):
    """The page's JavaScript is not where the server looks for it."""


def vendor_root() -> Path:
    """Where /vendor/ is served from: the wheel's own copy, else the checkout's ``web/node_modules``."""
    return PACKAGED if (PACKAGED / "three").is_dir() else CHECKOUT


def import_map() -> dict[str, str]:
    """The page's import map: bare specifier (or prefix ending in /) → URL under /vendor/."""
    page = (STATIC_DIR / "index.html").read_text(encoding="utf-8")
    m = _IMPORT_MAP.search(page)
    return json.loads(m.group(1))["imports"] if m else {}


def _map(specifier: str, imports: dict[str, str]) -> str | None:
    """A bare specifier → its file under /vendor/ (relative to the packages' folder), or None."""
    if specifier in imports:
        url = imports[specifier]
    else:
        prefix = max((p for p in imports if p.endswith("/") and specifier.startswith(p)), key=len, default=None)
        if prefix is None:
            return None
        url = imports[prefix] + specifier[len(prefix):]
    return url.removeprefix("/vendor/") if url.startswith("/vendor/") else None


def served_files(root: Path | None = None) -> list[str]:
    """Every file under ``root`` (default :func:`vendor_root`) that the page, /docs or a report can load: the
    closure of the imports from the page's modules and the report's viewer, and the files loaded by URL."""
    root = root or vendor_root()
    imports = import_map()
    found: set[str] = set()
    queue = [*LOADED_BY_URL, *REPORT_ENTRIES]
    own = [*sorted(STATIC_DIR.glob("*.js")), REPORT_VIEWER]
    for module in own:
        for _, spec in _SPECIFIER.findall(module.read_text(encoding="utf-8")):
            rel = _map(spec, imports)
            if rel:
                queue.append(rel)
    while queue:
        rel = queue.pop()
        if rel in found:
            continue
        path = root / rel
        if not path.is_file():
            raise AssetsMissing(f"{path} is missing")
        found.add(rel)
        if not rel.endswith((".js", ".mjs")):
            continue
        for _, spec in _SPECIFIER.findall(path.read_text(encoding="utf-8", errors="replace")):
            if spec.startswith(("./", "../")):
                target = posixpath.normpath(posixpath.join(posixpath.dirname(rel), spec))
                if (root / target).is_file():
                    queue.append(target)
            elif (mapped := _map(spec, imports)) is not None:
                queue.append(mapped)
    return sorted(found)


def check_assets(root: Path | None = None) -> Path:
    """The folder /vendor/ is served from, or :class:`AssetsMissing` naming the first file missing and the fix."""
    root = root or vendor_root()
    try:
        served_files(root)
    except AssetsMissing as exc:
        raise AssetsMissing(f"the page's JavaScript is missing ({exc}): in a checkout run `make setup` (it runs "
                            "`npm ci --prefix web`); a wheel built from such a checkout carries it") from None
    return root


def copy_assets(source: Path, target: Path) -> int:
    """Copy the served files of ``source`` (a node_modules folder) with each package's licence into ``target``;
    returns the bytes copied."""
    total = 0
    files = served_files(source)
    files += [f"{pkg}/{name}" for pkg in PACKAGES for name in KEEP if (source / pkg / name).is_file()]
    for rel in sorted(set(files)):
        dest = target / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source / rel, dest)
        total += dest.stat().st_size
    return total
