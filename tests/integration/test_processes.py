"""How the service's and the command line's processes are started, through real
processes: nothing in the working directory is imported by any of them, and ``texbake
serve`` says on which URL it listens."""

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import httpx
from conftest import upload, wait

TEXBAKE = str(Path(sys.executable).parent / "texbake")  # the console script, as a user runs it
HIJACK = """import pathlib, sys
pathlib.Path(__file__).with_suffix(".imported").write_text(" ".join(sys.argv))
sys.exit(1)
"""


def hostile_folder(folder: Path) -> Path:
    """A working folder holding a ``texbake.py`` and a ``service.py`` that leave a marker
    (``NAME.imported``) and exit 1 when imported."""
    folder.mkdir()
    for name in ("texbake.py", "service.py"):
        (folder / name).write_text(HIJACK)
    return folder


def serving_url(proc, log: Path, timeout: float = 60) -> str:
    """The URL serve's log says it listens on."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        found = re.search(r"serving on (http://\S+)", log.read_text(errors="replace"))
        if found:
            return found.group(1)
        assert proc.poll() is None, log.read_text()
        time.sleep(0.2)
    raise AssertionError(f"serve did not say where it listens: {log.read_text()[-2000:]}")


def test_files_in_the_working_directory_are_never_imported(tmp_path, meshes):
    cwd = hostile_folder(tmp_path / "cwd")
    env = {**os.environ, "BAKE_DATA_DIR": str(tmp_path / "data")}
    log = tmp_path / "serve.log"
    with open(log, "wb") as out:
        api = subprocess.Popen([TEXBAKE, "serve", "--port", "0", "--workers", "1"], cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        url = serving_url(api, log)
        job = wait(url, upload(url, meshes / "suzanne.ply", {"size": 64}).json()["id"], timeout=120)
        assert job["state"] == "done", job
        assert httpx.get(f"{url}/readyz", timeout=10).json()["workers"] == 1
    finally:
        api.terminate()
        assert api.wait(60) == 0, log.read_text()[-2000:]
    baked = subprocess.run([TEXBAKE, "bake", str(meshes / "suzanne.ply"), "--size", "64", "-o", str(tmp_path / "out")], cwd=cwd,
                           capture_output=True, text=True, timeout=300, env={k: v for k, v in os.environ.items() if k != "BAKE_DATA_DIR"})
    assert baked.returncode == 0, baked.stderr
    assert (tmp_path / "out" / "suzanne.glb").is_file()
    assert sorted(p.name for p in cwd.iterdir()) == ["service.py", "texbake.py"]  # no marker: neither was imported


def test_serve_says_where_it_listens(tmp_path):
    log = tmp_path / "serve.log"
    env = {**os.environ, "BAKE_DATA_DIR": str(tmp_path / "data")}
    with open(log, "wb") as out:
        api = subprocess.Popen([TEXBAKE, "serve", "--port", "0", "--workers", "0"], env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        url = serving_url(api, log)
        assert re.fullmatch(r"http://127\.0\.0\.1:\d+", url) and not url.endswith(":0"), url  # the port it was given
        assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200
        assert len(re.findall("serving on", log.read_text())) == 1
    finally:
        api.terminate()
        api.wait(60)
