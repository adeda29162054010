"""POST /v1/materials/mtlx through FastAPI's TestClient: a real MaterialX document (the
marble of MaterialX's resources/Materials/Examples/StandardSurface, copied into
tests/data/mtlx: the ``materialx`` wheel carries its libraries, not its resources) and
small documents written here for what cannot be baked or read."""

import io
import json
from pathlib import Path

import numpy as np
import pytest

from texbake.service.api.routes.mtlx import MAX_BYTES

MARBLE = Path(__file__).resolve().parents[2] / "data" / "mtlx" / "standard_surface_marble_solid.mtlx"


def shader_doc(body: str, shader: str = "standard_surface", inputs: str = "") -> str:
    """A document of ``body`` nodes and one shader ``SR`` (with ``inputs``) in material ``M``."""
    return (f'<?xml version="1.0"?>\n<materialx version="1.39">\n{body}\n'
            f'<{shader} name="SR" type="surfaceshader">{inputs}</{shader}>\n'
            '<surfacematerial name="M" type="material"><input name="surfaceshader" type="surfaceshader" nodename="SR"/>'
            "</surfacematerial>\n</materialx>\n")


WOOD = shader_doc('<image name="wood_image" type="color3"><input name="file" type="filename" value="wood.png"/></image>',
                  inputs='<input name="base_color" type="color3" nodename="wood_image"/>')
UNLIT = shader_doc("", "surface_unlit", '<input name="emission_color" type="color3" value="1, 0, 0"/>')


def read(client, text: str | bytes, name: str = "doc.mtlx"):
    data = text.encode() if isinstance(text, str) else text
    return client.post("/v1/materials/mtlx", files={"mtlx": (name, io.BytesIO(data), "application/xml")})


def every_file(folder: Path) -> set[str]:
    """Every file and folder under ``folder`` but the SQLite files of the jobs table and
    the queue (their journals come and go with the reaper's reads)."""
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if ".db" not in p.name}


def test_a_document_is_what_the_editor_shows(client):
    """The marble: its name, its shader, the base colour a graph of base_color x base, the
    roughness a constant, the shader's inputs not baked a warning; the material is the one
    ``--material FILE.mtlx`` makes, named by its file."""
    from texbake.cli import read_material

    r = read(client, MARBLE.read_bytes(), MARBLE.name)
    assert r.status_code == 200, r.text
    got = r.json()
    assert (got["name"], got["file"]) == ("Marble_3D", MARBLE.name)
    assert got["shader"] == {"category": "standard_surface", "name": "SR_marble1"}
    assert got["channels"] == {"base_color": {"inputs": ["base_color", "base"], "graph": True},
                               "roughness": {"inputs": ["specular_roughness"], "graph": False}}
    assert len(got["warnings"]) == 1 and "subsurface, subsurface_color" in got["warnings"][0], got["warnings"]
    material = got["material"]
    assert material["base_color"]["op"] == "mtlx" and material["base_color"]["path"] == MARBLE.name
    assert material["roughness"] == pytest.approx(0.1)
    cli = read_material(str(MARBLE)).model_dump(mode="json")  # the command line's, its path the file's whole path
    cli["base_color"]["path"] = MARBLE.name
    cli["description"] = cli["description"].replace(str(MARBLE), MARBLE.name)
    assert material == cli


def test_the_material_answered_is_swatched_and_baked_as_given(client, meshes, tmp_path):
    """What the page does with the answer: a swatch of its base colour (the marble's veins:
    not one colour), and a job with it as the material, queued with the document."""
    from texbake.output.images import read_image

    material = read(client, MARBLE.read_text(), MARBLE.name).json()["material"]
    r = client.post("/v1/swatch", json={"material": material, "channel": "base_color", "size": 64})
    assert r.status_code == 200 and r.headers["content-type"] == "image/png", r.text
    (tmp_path / "s.png").write_bytes(r.content)
    image = read_image(tmp_path / "s.png")
    disk = image[image[..., 3] == 1][:, :3]
    assert disk.shape[0] > 1000 and np.ptp(disk, axis=0).max() > 0.2, np.ptp(disk, axis=0)
    with open(meshes / "suzanne.ply", "rb") as f:
        job = client.post("/v1/jobs", files={"mesh": ("suzanne.ply", f)}, data={"settings": json.dumps({"material": material, "size": 64})})
    assert job.status_code == 202, job.text
    assert job.json()["settings"]["material"] == material


@pytest.mark.parametrize("text, status, words", [
    (WOOD, 422, "mtlx: doc.mtlx: node 'wood_image': image: an image node reads a file, and texbake bakes procedural graphs "
                "(supported: "),
    (UNLIT, 422, "mtlx: doc.mtlx: node 'SR': surface_unlit: not a surface shader texbake reads (supported: standard_surface, "),
    ('<?xml version="1.0"?>\n<materialx version="1.39"><standard_surface name="SR"', 422,
     "mtlx: doc.mtlx: not a readable MaterialX document: "),
    (shader_doc('<xi:include href="/etc/hostname"/>'), 422, "mtlx: doc.mtlx: includes another file (<xi:include "
                                                              'href="/etc/hostname"/>): a document given as text reads no other file'),
    (b"\xff\xfe<materialx/>", 422, "mtlx: 'doc.mtlx' is not UTF-8 text (byte 0)"),
    ("  \n", 422, "mtlx: 'doc.mtlx' is empty"),
    (MARBLE.read_text() + "<!--" + "x" * MAX_BYTES + "-->", 413, f"mtlx: 'doc.mtlx' is larger than the limit of {MAX_BYTES} bytes"),
])
def test_what_cannot_be_read_is_a_4xx_naming_it(client, text, status, words):
    """Each answer JSON with one line naming the node and its category where there is one;
    nothing is written to the data folder, whatever is sent."""
    from texbake.service.core.config import get_settings

    data = get_settings().data_dir
    before = every_file(data)
    r = read(client, text)
    assert r.status_code == status and r.json()["detail"].startswith(words), r.text
    if "node '" in words:
        assert r.json()["node"] == words.split("node '")[1].split("'")[0]
    assert every_file(data) == before


def test_only_a_mtlx_file_is_taken(client):
    r = read(client, MARBLE.read_text(), "marble.xml")
    assert r.status_code == 422 and r.json()["detail"] == "mtlx: 'marble.xml' is not a MaterialX document (.mtlx)"
    assert client.post("/v1/materials/mtlx").status_code == 422  # no part at all: the field named
    assert client.get("/v1/materials").json()["mtlx_max_bytes"] == MAX_BYTES  # what the page checks before sending
