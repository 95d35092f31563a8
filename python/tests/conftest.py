import json
import os
import pathlib
import subprocess

import pytest

SCENES = pathlib.Path(os.environ.get("PGI_SCENES_DIR", pathlib.Path(__file__).resolve().parents[2] / "tools" / "scenes"))
BAD_SCENES = pathlib.Path(os.environ.get("PGI_BAD_SCENES_DIR", SCENES.parent.parent / "tests" / "bad_scenes"))
PGI = os.environ.get("PGI_BINARY", "pgi")


def cli(*args, check=True):
    """pgi's command line: (exit code, stdout, stderr)."""
    p = subprocess.run([PGI, *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"pgi {' '.join(map(str, args))} exited {p.returncode}: {p.stderr}")
    return p.returncode, p.stdout, p.stderr


def cli_json(*args):
    return json.loads(cli(*args, "--json")[1])


@pytest.fixture(params=sorted(p.stem for p in SCENES.glob("*.toml")))
def scene(request):
    return SCENES / f"{request.param}.toml"
