"""The command line, run as a real process."""

import json
import os
import re
import shutil
from pathlib import Path

import pytest
from conftest import run_cli


def _lines(stderr: str) -> list[str]:
    return stderr.splitlines()


def test_bake_writes_maps_mesh_and_report(meshes, tmp_path):
    r = run_cli("bake", meshes / "bunny.ply", "--texture", "checker", "--size", 128, "--out", tmp_path / "o")
    assert r.returncode == 0, r.stderr
    out = tmp_path / "o"
    assert {"albedo.png", "coverage.png", "bunny.glb", "report.json"} <= {p.name for p in out.iterdir()}
    report = json.loads((out / "report.json").read_text())
    assert report["atlas"]["method"] == "planar" and report["texels"]["covered"] > 1000


@pytest.mark.parametrize(
    "args, words",
    [
        (["bake", "{meshes}/nope.obj"], "nope.obj"),
        (["bake", "{meshes}/bunny.ply", "--size", "0"], "size"),
        (["bake", "{meshes}/bunny.ply", "--texture", "marbel"], "marbel"),
        (["bake", "{meshes}/bunny.ply", "--format", "bmp"], "format"),
        (["bake", "{meshes}/bunny.ply", "--uv", "keep"], "UV"),
    ],
)
def test_user_errors_exit_2_with_one_line(meshes, tmp_path, args, words):
    args = [a.format(meshes=meshes) for a in args] + ["--out", str(tmp_path / "o")]
    r = run_cli(*args)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert words.lower() in lines[0].lower()


def test_batch_keeps_going_and_exits_1_on_a_failure(meshes, tmp_path):
    bad = tmp_path / "broken.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    manifest = tmp_path / "list.jsonl"
    manifest.write_text(json.dumps({"mesh": str(meshes / "BoxTextured.glb"), "size": 32}) + "\n")
    r = run_cli("batch", meshes / "suzanne.ply", bad, manifest, "--out", tmp_path / "o", "--size", 64, "--jobs", 2)
    assert r.returncode == 1, r.stderr
    assert "broken.obj" in r.stdout and "failed" in r.stdout and r.stdout.count("done") == 2
    assert (tmp_path / "o" / "suzanne" / "report.json").exists()
    assert json.loads((tmp_path / "o" / "BoxTextured" / "report.json").read_text())["settings"]["size"] == 32


def test_batch_summary_as_json_with_atlas_warnings_and_whole_paths(meshes, tmp_path):
    """Globs take only mesh files (capsule.obj's .mtl and .jpg stay out); per-item seconds
    are the bake's own; the atlas and the warnings are in the summary; paths are whole."""
    import shutil

    for name in ("capsule.obj", "capsule.mtl", "capsule0.jpg", "Duck.glb"):
        shutil.copy(meshes / name, tmp_path / name)
    out = tmp_path / ("a-long-output-folder-name-" * 4)
    r = run_cli("batch", tmp_path / "*", "--out", out, "--size", 32, "--uv", "keep", "--json")
    assert r.returncode == 0, r.stderr
    rows = {Path(row["mesh"]).name: row for row in json.loads(r.stdout)}
    assert set(rows) == {"capsule.obj", "Duck.glb"}
    assert rows["Duck.glb"]["atlas"] == "kept" and "overlap" in rows["Duck.glb"]["warnings"][0]
    assert rows["capsule.obj"]["warnings"] == []
    for row in rows.values():  # each item's own bake and save: at least the report's stages, not much more
        seconds = json.loads((Path(row["out"]) / "report.json").read_text())["seconds"]
        wall = sum(seconds[stage] for stage in WALL_STAGES)
        # every stage timed (a 32² bake of kept UVs takes 0.03 s of them now, some stages
        # under the report's 0.1 ms), and the item's time covers them
        assert 0 < wall <= row["seconds"] <= wall + 5, (row["seconds"], seconds)
    table = run_cli("batch", tmp_path / "*.obj", "--out", out, "--size", 32)  # not a terminal: nothing cut
    assert table.returncode == 0 and str(out / "capsule") in table.stdout
    assert rows["capsule.obj"]["atlas"] in table.stdout


def test_a_killed_batch_takes_its_bake_processes_and_their_workers_with_it(meshes, tmp_path):
    import signal
    import subprocess
    import sys
    import time

    import psutil

    for k in range(6):  # enough unwrapped bakes that the batch is still at work when killed
        shutil.copy(meshes / "bunny.ply", tmp_path / f"bunny{k}.ply")
    batch = subprocess.Popen([sys.executable, "-m", "texbake.cli", "batch", str(tmp_path / "*.ply"), "--out", str(tmp_path / "o"),
                              "--jobs", "2", "--no-cache", "--size", "1024"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        children: list = []
        while len(children) < 4 and time.monotonic() < deadline:  # two bake processes, each with its packing workers
            children = psutil.Process(batch.pid).children(recursive=True)
            time.sleep(0.2)
        assert len(children) >= 4, children
        batch.send_signal(signal.SIGKILL)
        batch.wait()
        gone, alive = psutil.wait_procs(children, timeout=15)
        assert not alive, [p.cmdline()[-1:] for p in alive]
    finally:
        batch.kill()
        for p in psutil.Process().children(recursive=True):
            p.kill()


# Run as a subreaper (PR_SET_CHILD_SUBREAPER), so that a process the batch's processes leave
# behind comes to this one rather than to init: after the batch, its children here are those.
SUBREAPER = """
import ctypes, json, subprocess, sys, time
import psutil
ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)
code = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
time.sleep(1.0)
left = []
for p in psutil.Process().children():
    try:
        left.append(" ".join(p.cmdline()) or p.name())
    except psutil.Error:  # a zombie: ended, never waited for
        left.append(f"pid {p.pid}, ended, not waited for")
print(json.dumps({"code": code, "left": left}))
"""


def test_a_finished_batch_waits_for_its_packing_workers(meshes, tmp_path):
    # The bake processes are forked, and a forked process leaves by os._exit, without
    # atexit: its warm packing workers must still be ended and waited for, else they are
    # orphans (and their CPU time is missing from the batch's, which bench_batch reads).
    import subprocess
    import sys

    for k in range(2):
        shutil.copy(meshes / "bunny.ply", tmp_path / f"bunny{k}.ply")
    cmd = [sys.executable, "-m", "texbake.cli", "batch", str(tmp_path / "*.ply"), "--out", str(tmp_path / "o"), "--jobs", "2",
           "--no-cache", "--size", "256"]
    r = subprocess.run([sys.executable, "-c", SUBREAPER, *cmd], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    found = json.loads(r.stdout)
    assert found["code"] == 0
    assert found["left"] == []


WALL_STAGES = ("load", "atlas", "normals", "prepare", "tiles (wall)", "estimate", "margin")  # one after another: the bake


def test_textures_lists_every_texture_and_its_schema():
    r = run_cli("textures")
    assert r.returncode == 0
    for name in ("checker", "noise", "turbulence", "fbm", "marble", "wood", "flame"):
        assert name in r.stdout
    schema = json.loads(run_cli("textures", "--json").stdout)
    assert schema["discriminator"]["propertyName"] == "name"
    assert {"Marble", "Wood", "Flame"} <= set(schema["$defs"])


def test_version():
    from texbake import __version__

    r = run_cli("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"texbake {__version__}" and __version__ != "0+unknown"


def test_bad_spec_files_exit_2_with_one_line(meshes, tmp_path):
    (tmp_path / "list.yaml").write_text("- name: wood\n")
    (tmp_path / "broken.json").write_text("{name: ")
    for spec, words in ((tmp_path / "missing.yaml", "cannot read"), (tmp_path / "list.yaml", "one mapping"),
                        (tmp_path / "broken.json", "not a valid spec file")):
        r = run_cli("bake", meshes / "suzanne.ply", "--texture", spec, "--out", tmp_path / "o")
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and words in r.stderr, r.stderr
        assert str(spec) in r.stderr


def test_spec_file_and_overrides(meshes, tmp_path):
    spec = tmp_path / "wood.yaml"
    spec.write_text("name: wood\nring_width: 0.08\ntilt: [0, 90, 0]\n")
    r = run_cli("bake", meshes / "suzanne.ply", "--texture", spec, "--set", "wobble=0.1", "--set", "colormap.knots=[0, 1]",
                "--size", 64, "--out", tmp_path / "o")
    assert r.returncode == 0, r.stderr
    texture = json.loads((tmp_path / "o" / "report.json").read_text())["settings"]["texture"]
    assert texture["ring_width"] == 0.08 and texture["wobble"] == 0.1 and texture["tilt"] == [0, 90, 0]
    bad = run_cli("bake", meshes / "suzanne.ply", "--texture", "marble", "--set", "turbulence.octavs=6", "--out", tmp_path / "p")
    assert bad.returncode == 2 and "octavs" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    bad = run_cli("bake", meshes / "suzanne.ply", "--texture", "marble", "--set", "turbulence.octaves=99", "--out", tmp_path / "p")
    assert bad.returncode == 2 and "octaves" in bad.stderr


def test_report_writes_the_sweep(meshes, tmp_path):
    out = tmp_path / "rep"
    r = run_cli("report", meshes / "suzanne.ply", "--texture", "marble", "--size", 32, "--repeats", 1,
                "--reference-samples", 64, "--out", out)
    assert r.returncode == 0, r.stderr
    assert {"error_vs_time.csv", "error_vs_time.png", "error_vs_time.md"} <= {p.name for p in out.iterdir()}
    assert "| setting | seconds |" in r.stdout and "1spp filter f64 32" in r.stdout


@pytest.mark.parametrize(
    "args, words",
    [
        (["report", "{meshes}/bunny.ply", "--size", "2"], "size"),
        (["report", "{meshes}/bunny.ply", "--repeats", "0"], "repeats"),
        (["report", "{meshes}/bunny.ply", "--texture", "marbel"], "marbel"),
        (["report", "{meshes}/bunny.ply", "--size", "big"], "size"),
        (["bake", "{meshes}/bunny.ply", "--quality", "best"], "quality"),
    ],
)
def test_report_and_quality_user_errors_exit_2_with_one_line(meshes, tmp_path, args, words):
    r = run_cli(*[a.format(meshes=meshes) for a in args], "--out", tmp_path / "o")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr and words in lines[0].lower()


def test_bake_quality_preset_and_override(meshes, tmp_path):
    r = run_cli("bake", meshes / "suzanne.ply", "--texture", "marble", "--quality", "final", "--samples", 4, "--size", 32,
                "--out", tmp_path / "o")
    assert r.returncode == 0, r.stderr
    p = json.loads((tmp_path / "o" / "report.json").read_text())["settings"]
    assert (p["quality"], p["samples"], p["filtering"]) == ("final", 4, False)


@pytest.mark.parametrize("args, line", [
    (["--size", "abc"], "size: expected a whole number from 1 to 65536 (or width,height), got 'abc'"),
    (["--size", "64,x"], "size: expected a whole number from 1 to 65536 (or width,height), got '64,x'"),
    (["--texture", "marble", "--set", "octaves=6"], "set: marble has no parameter 'octaves' (did you mean 'turbulence.octaves'? "
     "it has: axis, frequency, amplitude, turbulence, colormap, transform, space, model)"),
    (["--texture", '{"name": "marble", x}'], "texture: not valid JSON at line 1 column 20: expecting property name enclosed in double quotes"),
    (["--texture", "marbel"], "texture: unknown texture 'marbel' (did you mean 'marble'? known: checker, fbm, flame, marble, noise, "
     "position, turbulence, wood)"),
    (["--uv", "sideways"], "uv: expected one of 'auto', 'unwrap', 'keep', got 'sideways'"),
])
def test_a_bad_setting_is_named_with_its_value_and_what_is_allowed(meshes, tmp_path, args, line):
    r = run_cli("bake", meshes / "suzanne.ply", *args, "--out", tmp_path / "o")
    assert (r.returncode, _lines(r.stderr)) == (2, [f"texbake: error: {line}"]), r.stderr


def test_bake_progress_is_plain_lines_off_a_terminal(meshes, tmp_path, monkeypatch):
    """Off a terminal (a CI log) a bake writes a progress line at most every
    $TEXBAKE_PROGRESS_SECONDS (10): none for a short bake; 0 writes one a step."""
    r = run_cli("bake", meshes / "suzanne.ply", "--size", 64, "--out", tmp_path / "a")
    assert r.returncode == 0 and _lines(r.stderr) == [] and r.stdout.startswith(f"{meshes / 'suzanne.ply'}: "), r.stderr
    monkeypatch.setenv("TEXBAKE_PROGRESS_SECONDS", "0")
    r = run_cli("bake", meshes / "suzanne.ply", "--size", 64, "--out", tmp_path / "b")
    assert r.returncode == 0, r.stderr
    found = [re.fullmatch(r"texbake: suzanne\.ply: (\d+)% after (\d+) s", line) for line in _lines(r.stderr)]
    assert all(found), r.stderr
    percents = [int(m.group(1)) for m in found if m]
    assert percents[0] == 5 and 30 in percents and percents[-1] == 95 and percents == sorted(percents), percents
    assert len(r.stdout.splitlines()) == 1  # the summary, on stdout


def _on_a_terminal(args, timeout=300) -> tuple[int, bytes, bytes]:
    """Run the command line with stderr on a pseudo-terminal: (exit code, stdout, what the terminal got)."""
    import pty
    import select
    import subprocess
    import sys

    master, slave = pty.openpty()
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "120"}
    process = subprocess.Popen([sys.executable, "-m", "texbake.cli", *map(str, args)], stdout=subprocess.PIPE, stderr=slave, env=env)
    os.close(slave)
    shown = b""
    try:
        while process.poll() is None or select.select([master], [], [], 0)[0]:
            if select.select([master], [], [], 0.2)[0]:
                try:
                    shown += os.read(master, 1 << 16)
                except OSError:  # the terminal's other end closed
                    break
        out = process.stdout.read() if process.stdout else b""
        return process.wait(timeout), out, shown
    finally:
        os.close(master)
        if process.stdout:
            process.stdout.close()


def test_bake_progress_is_a_bar_on_a_terminal_and_quiet_says_nothing(meshes, tmp_path):
    code, out, shown = _on_a_terminal(["bake", meshes / "suzanne.ply", "--size", 128, "--out", tmp_path / "a"])
    assert code == 0 and out.decode().startswith(f"{meshes / 'suzanne.ply'}: "), shown[-500:]
    assert b"suzanne.ply" in shown and "━".encode() in shown and b"%" in shown, shown[-500:]
    code, out, shown = _on_a_terminal(["bake", meshes / "suzanne.ply", "--size", 128, "--quiet", "--out", tmp_path / "b"])
    assert (code, out) == (0, b"") and shown.strip() == b"", shown[-500:]
    assert (tmp_path / "b" / "albedo.png").exists()


def test_a_bake_too_large_for_the_memory_is_refused_with_the_figure(meshes, tmp_path, monkeypatch):
    """Refused after loading the mesh, before its atlas is made (none is kept): exit 2, one line."""
    from texbake.memory import available_bytes, bake_bytes, gigabytes
    from texbake.mesh.load import load_mesh
    from texbake.settings import BakeSettings

    faces = len(load_mesh(meshes / "suzanne.ply").faces)
    monkeypatch.setenv("TEXBAKE_CACHE", str(tmp_path / "cache"))
    # 64 frames of 65536² need terabytes: refused anywhere
    need = bake_bytes(BakeSettings.build(size=65536, texture="flame", frames=list(range(64))), faces, workers=2)
    r = run_cli("bake", meshes / "suzanne.ply", "--size", 65536, "--texture", "flame", "--frames", "0:63:64", "--out", tmp_path / "o")
    assert r.returncode == 2 and re.fullmatch(rf"texbake: error: size: a 65536x65536 bake needs about {gigabytes(need)}; "
                                              r"[\d.]+ GB are available", r.stderr.strip()), r.stderr
    assert not (tmp_path / "o").exists() and not any((tmp_path / "cache").rglob("*.*"))
    need = bake_bytes(BakeSettings.build(size=65536), faces, workers=2)
    if available_bytes() > need:
        pytest.skip(f"this machine has the {gigabytes(need)} a 65536² bake needs")
    r = run_cli("bake", meshes / "suzanne.ply", "--size", 65536, "--out", tmp_path / "o")
    assert r.returncode == 2 and re.fullmatch(rf"texbake: error: size: a 65536x65536 bake needs about {gigabytes(need)}; "
                                              r"[\d.]+ GB are available", r.stderr.strip()), r.stderr


def test_batch_takes_a_folder_of_meshes(meshes, tmp_path):
    """A folder is every mesh file in it (by extension, not its sub-folders), sorted; an empty one is an error."""
    folder = tmp_path / "in"
    (folder / "sub").mkdir(parents=True)
    for name in ("suzanne.ply", "capsule.obj", "capsule.mtl", "capsule0.jpg"):
        shutil.copy(meshes / name, folder / name)
    shutil.copy(meshes / "BoxTextured.glb", folder / "sub" / "BoxTextured.glb")
    (folder / "notes.txt").write_text("not a mesh\n")
    r = run_cli("batch", f"{folder}/", "--out", tmp_path / "o", "--size", 16, "--json")
    assert r.returncode == 0, r.stderr
    assert [Path(row["mesh"]).name for row in json.loads(r.stdout)] == ["capsule.obj", "suzanne.ply"]
    empty = tmp_path / "empty"
    (empty / "sub").mkdir(parents=True)
    (empty / "capsule.mtl").write_text("")
    r = run_cli("batch", empty, "--out", tmp_path / "o")
    assert (r.returncode, _lines(r.stderr)) == (2, [f"texbake: error: {empty}: no mesh file in this folder "
                                                    "(looked for .obj .ply .stl .off .gltf .glb)"]), r.stderr


@pytest.mark.parametrize("texture", ["checker", "marble"])
def test_the_first_bake_compiles_nothing_and_says_nothing(meshes, tmp_path, monkeypatch, texture):
    """The kernels are compiled ahead of time (texbake._native): a first bake, with every
    cache empty, writes nothing to stderr under --quiet, as the second does."""
    monkeypatch.setenv("TEXBAKE_CACHE", str(tmp_path / "cache"))
    for out in ("a", "b"):
        r = run_cli("bake", meshes / "suzanne.ply", "--texture", texture, "--size", 16, "--quiet", "--out", tmp_path / out)
        assert (r.returncode, r.stderr) == (0, ""), r.stderr
        assert (tmp_path / out / "albedo.png").exists()


def test_uv_keep_on_a_scene_with_uvs_on_some_parts_keeps_them_and_says_which_part_has_none(tmp_path):
    """--uv keep keeps the crate's UVs, unwraps the ball and says so on stderr, one line
    each, ``texbake: warning: <mesh>: ...``; the report holds the same lines."""
    from conftest import mixed_uv_scene

    mixed_uv_scene(tmp_path / "scene.glb", 0.5)
    r = run_cli("bake", tmp_path / "scene.glb", "--size", 64, "--uv", "keep", "--texture-set", "single", "--no-cache", "--out", tmp_path / "o")
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["atlas"]["method"].startswith("kept+") and report["atlas"]["kept_scale"] == 1.0
    warned = [line for line in _lines(r.stderr) if line.startswith("texbake: warning:")]
    assert warned == [f"texbake: warning: {tmp_path / 'scene.glb'}: {w}" for w in report["warnings"]]
    assert "part 'ball' (320 faces) has no UVs" in warned[0]


def test_a_material_file_bakes_every_channel_and_packs(meshes, tmp_path):
    (tmp_path / "rust.yaml").write_text(
        "nodes:\n  patches: {op: texture, output: value, texture: {name: fbm, scale: 5}}\n"
        "  rust: {op: smoothstep, input: patches, edge0: 0.45, edge1: 0.55}\n"
        "base_color: {op: mix, a: [0.5, 0.5, 0.52], b: [0.4, 0.15, 0.05], mask: rust}\n"
        "metallic: {op: invert, input: rust}\nroughness: {op: mix, a: 0.3, b: 0.9, mask: rust}\nheight: rust\n")
    r = run_cli("bake", meshes / "suzanne.ply", "--material", tmp_path / "rust.yaml", "--size", 64, "--normal-convention", "directx",
                "--packing", "orm,hdrp-mask", "--out", tmp_path / "o")
    assert r.returncode == 0, r.stderr
    names = {p.name for p in (tmp_path / "o").iterdir()}
    assert {"base_color.png", "metallic.png", "roughness.png", "height.png", "normal.png", "normal_gltf.png", "orm.png",
            "hdrp-mask.png", "suzanne.glb"} <= names and "albedo.png" not in names
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["settings"]["material"]["nodes"]["rust"]["edge1"] == 0.55 and report["settings"]["normal_convention"] == "directx"
    assert [t["name"] for t in report["settings"]["packing"]] == ["orm", "hdrp-mask"]
    built_in = run_cli("bake", meshes / "suzanne.ply", "--material", "lava", "--size", 32, "--out", tmp_path / "lava")
    assert built_in.returncode == 0 and (tmp_path / "lava" / "emissive.png").exists(), built_in.stderr


@pytest.mark.parametrize(("material", "line"), [
    ('{"nodes": {"a": {"op": "invert", "input": "b"}, "b": {"op": "add", "a": "a", "b": 1}}, "base_color": "a"}',
     "texbake: error: material: node 'a': a cycle: a -> b -> a"),
    ('{"base_color": {"op": "mixx", "a": 1}}', "texbake: error: material: node 'base_color': unknown op 'mixx' (did you mean 'mix'?"),
    ('{"base_color": {"op": "mix", "a": 0, "b": 1, "mask": {"name": "marble"}}}',
     "texbake: error: material: node 'base_color': input 'mask' takes a scalar, got a colour"),
    ("glass", "texbake: error: material: unknown material 'glass'"),
])
def test_a_graph_error_is_one_line_naming_the_node_and_exit_2(meshes, tmp_path, material, line):
    r = run_cli("bake", meshes / "suzanne.ply", "--material", material, "--out", tmp_path / "o")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (got,) = r.stderr.strip().splitlines()
    assert got.startswith(line), got
    assert not (tmp_path / "o").exists()


def test_bad_material_files_exit_2_naming_the_file(meshes, tmp_path):
    (tmp_path / "list.yaml").write_text("- base_color: 1\n")
    for path, words in ((tmp_path / "missing.json", "cannot read material file"), (tmp_path / "list.yaml", "one mapping of channels")):
        r = run_cli("bake", meshes / "suzanne.ply", "--material", path, "--out", tmp_path / "o")
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and words in r.stderr and str(path) in r.stderr, r.stderr


def test_materials_lists_the_built_ins_and_prints_one():
    r = run_cli("materials")
    assert r.returncode == 0
    for name in ("polished_marble", "oak_planks", "lava", "rusted_iron", "glazed_ceramic_checker", "smoothstep"):
        assert name in r.stdout
    lava = json.loads(run_cli("materials", "lava").stdout)
    assert lava["name"] == "lava" and "emissive" in lava
    assert json.loads(run_cli("materials", "--json").stdout)["title"] == "Material"
    bad = run_cli("materials", "lavva")
    assert bad.returncode == 2 and "unknown material 'lavva'" in bad.stderr
def test_a_manifest_line_gives_two_materials_two_textures(tmp_path):
    """One manifest line, its ``materials`` mapping: the body checker, the wheels wood
    (from a spec file) at 32²; each set's map is the one a bake of that texture alone gives,
    and ``bake --materials`` takes the same mapping from a file."""
    import numpy as np
    from conftest import two_material_scene

    import texbake
    from texbake.output.images import read_image, srgb_encode

    two_material_scene(tmp_path / "cart.glb")
    (tmp_path / "wood.json").write_text(json.dumps({"name": "wood", "ring_width": 0.05}))
    materials = {"body": {"texture": "checker"}, "wheels": {"texture": str(tmp_path / "wood.json"), "size": 32}}
    manifest = tmp_path / "list.jsonl"
    manifest.write_text(json.dumps({"mesh": "cart.glb", "size": 48, "texture": "marble", "materials": materials}) + "\n")
    r = run_cli("batch", manifest, "--out", tmp_path / "o", "--jobs", 1, "--no-cache")
    assert r.returncode == 0, r.stderr
    out = tmp_path / "o" / "cart"
    report = json.loads((out / "report.json").read_text())
    assert {s["name"]: s["settings"]["texture"]["name"] for s in report["sets"]} == {"body": "checker", "wheels": "wood"}
    body = texbake.bake_mesh(tmp_path / "cart.glb", "checker", size=48)
    wheels = texbake.bake_mesh(tmp_path / "cart.glb", {"name": "wood", "ring_width": 0.05}, size=32)
    for name, alone in [("body", body), ("wheels", wheels)]:
        want = next(s for s in alone.sets if s.name == name).images["albedo"]
        got = read_image(out / f"{name}_albedo.png")
        levels = lambda a: np.rint(srgb_encode(a) * 255)
        assert got.shape == want.shape and np.abs(levels(got) - levels(want)).max() <= 1  # the PNG's rounding
    (tmp_path / "materials.yaml").write_text(json.dumps(materials))
    r = run_cli("bake", tmp_path / "cart.glb", "--size", 48, "--materials", tmp_path / "materials.yaml", "--no-cache", "--out", tmp_path / "b")
    assert r.returncode == 0, r.stderr
    assert np.array_equal(read_image(tmp_path / "b" / "wheels_albedo.png"), read_image(out / "wheels_albedo.png"))
    r = run_cli("bake", tmp_path / "cart.glb", "--materials", '{"wheel": {}}', "--no-cache", "--out", tmp_path / "c")
    assert r.returncode == 2 and re.search(r"^texbake: error: materials: .*cart.glb has no material 'wheel'; its materials: ", r.stderr)


def test_the_program_ends_after_every_exit_handler_keeping_its_code_and_output(tmp_path):
    import subprocess
    import sys

    # as a library a command uses registers an exit handler; output left in stdout's buffer;
    # an object whose finaliser only the interpreter's teardown would run
    code = ("import atexit, sys\nfrom texbake import cli\nmark = sys.argv[1]\n"
            "atexit.register(lambda: open(mark, 'w').write('ran'))\n"
            "class Teardown:\n    def __del__(self):\n        print('torn down')\n"
            "kept = Teardown()\nsys.stdout.write('buffered ')\n"
            "sys.argv = ['texbake', 'bake', sys.argv[2], '--out', sys.argv[3]]\ncli.run()\n")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "mark"), str(tmp_path / "nope.obj"), str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "nope.obj: no such file" in done.stderr
    assert (tmp_path / "mark").read_text() == "ran"
    assert done.stdout == "buffered "  # flushed; and no teardown ran after the last handler


def test_the_program_ends_quietly_with_its_output_closed():
    import subprocess
    import sys

    # started with descriptor 1 closed (`texbake --version >&-`): Python's sys.stdout is None
    done = subprocess.run([sys.executable, "-m", "texbake.cli", "--version"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, timeout=120, preexec_fn=lambda: os.close(1))
    assert done.returncode == 0 and done.stderr == ""
