"""The wheel carries the page's JavaScript: building it copies, from ``web/node_modules`` (``npm ci --prefix web``),
the files the page, /docs and the HTML reports load into ``sightplan/web/vendor/`` (see sightplan/assets.py).
Everything else about the package is in pyproject.toml."""

import importlib.util
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


class BuildWithAssets(build_py):
    def run(self):
        super().run()
        if self.editable_mode:  # an editable install serves web/node_modules of the checkout
            return
        spec = importlib.util.spec_from_file_location("_assets", HERE / "src" / "sightplan" / "assets.py")
        assets = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(assets)
        source = HERE / "web" / "node_modules"
        try:
            size = assets.copy_assets(source, Path(self.build_lib) / "sightplan" / "web" / "vendor")
        except assets.AssetsMissing as exc:
            raise SystemExit(f"error: the wheel needs the page's JavaScript ({exc}); run `npm ci --prefix web` "
                             "first (make setup does)") from None
        print(f"sightplan: the page's JavaScript packaged ({size / 1e6:.1f} MB)")


setup(cmdclass={"build_py": BuildWithAssets})
