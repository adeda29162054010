"""The command line, run as a real process."""

import json
from pathlib import Path

import pytest
from conftest import run_cli


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
    assert rows["capsule.obj"]["warnings"] == [] and all(0 < row["seconds"] < 60 for row in rows.values())
    table = run_cli("batch", tmp_path / "*.obj", "--out", out, "--size", 32)  # not a terminal: nothing cut
    assert table.returncode == 0 and str(out / "capsule") in table.stdout
    assert rows["capsule.obj"]["atlas"] in table.stdout


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
