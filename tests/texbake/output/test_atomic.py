"""Atomic writes: the temporary files of a killed writer are cleared, a live one's kept."""

import os
import subprocess
import sys

from texbake.output.atomic import remove_stale, replacing, write_bytes
from texbake.output.save import save_result


def dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_remove_stale_takes_a_dead_writers_files_only(tmp_path):
    dead = tmp_path / f".albedo.png.tmp-{dead_pid()}-0123abcd.png"
    live = tmp_path / f".coverage.png.tmp-{os.getpid()}-89abcdef.png"
    other = tmp_path / ".notes.tmp-x"  # not one of replacing()'s names
    for path in (dead, live, other):
        path.write_bytes(b"half")
    assert remove_stale(tmp_path) == [dead.name]
    assert not dead.exists() and live.exists() and other.exists()
    assert remove_stale(tmp_path / "missing") == []


def test_replacing_names_are_the_ones_remove_stale_knows(tmp_path):
    with replacing(tmp_path / "a.png", ".png") as tmp:
        tmp.write_bytes(b"x")
        assert remove_stale(tmp_path) == []  # this process is alive
    write_bytes(tmp_path / "b.bin", b"y")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.bin"]


def test_a_bake_saved_into_a_folder_clears_a_killed_bakes_leftovers(meshes, tmp_path):
    import texbake

    out = tmp_path / "out"
    out.mkdir()
    left = out / f".albedo.png.tmp-{dead_pid()}-0123abcd.png"
    left.write_bytes(b"")
    result = texbake.bake_mesh(meshes / "suzanne.ply", "checker", size=32)
    save_result(result, out)
    assert not left.exists() and (out / "report.json").exists()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
