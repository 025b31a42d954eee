"""Optional parts (extras) missing: one clear error naming the extra to install, not an ImportError."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

# runs the CLI with some modules made unimportable (a None in sys.modules makes `import` raise ImportError)
RUN = textwrap.dedent("""
    import sys
    for name in sys.argv[1].split(","):
        sys.modules[name] = None
    from sightplan.cli.main import app
    sys.argv = ["sightplan", *sys.argv[2:]]
    app()
""")


def run_without(modules: list[str], *args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", RUN, ",".join(modules), *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


@pytest.mark.parametrize("blocked, args, extra", [
    (["fastapi"], ["serve", "--data", "d"], "web"),
    # in make bench: the same message for another command of the web extra, and for the cluster extra
    pytest.param(["argon2"], ["users", "list", "--data", "d"], "web", marks=pytest.mark.bench),
    pytest.param(["distributed"], ["evaluate", "sample", "--ring-frames", "2", "--cluster", "local:1", "--out", "o"],
                 "cluster", marks=pytest.mark.bench),
    (["moderngl"], ["evaluate", "sample", "--ring-frames", "2", "--engine", "gl", "--out", "o"], "gl"),
])
def test_a_missing_extra_is_named_with_its_install_command(tmp_path, blocked, args, extra):
    res = run_without(blocked, *args, cwd=tmp_path)
    assert res.returncode == 2, (res.stdout, res.stderr)
    err = res.stderr.strip()
    assert err.startswith("error:") and "Traceback" not in res.stderr, err
    assert f"pip install 'sightplan[{extra}]'" in err, err
