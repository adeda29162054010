"""One bake in its own process: ``python -m service.bakejob JOB_DIR``.

Reads ``JOB_DIR/job.json`` (mesh file name and bake settings), bakes into
``JOB_DIR/out.tmp``, and writes ``JOB_DIR/outcome.json``: ``{"ok": true}`` or
``{"ok": false, "error": ...}``. Exit code 0, or 2 for a bad mesh or settings.
The parent (``service.tasks``) sets the deadline and the memory limit.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path


def main(job_dir: Path) -> int:
    from bake import BakeError, bake_mesh

    os.chdir(job_dir)  # errors name the mesh as uploaded, not the server's folders
    job = json.loads(Path("job.json").read_text())
    settings = dict(job["settings"])
    save = {k: settings.pop(k) for k in ("fmt", "bits") if k in settings}
    try:
        result = bake_mesh(Path(job["mesh"]), settings.pop("texture"), **settings)
        result.save(Path("out.tmp"), **save)
    except BakeError as exc:
        Path("outcome.json").write_text(json.dumps({"ok": False, "error": str(exc)}))
        return 2
    Path("outcome.json").write_text(json.dumps({"ok": True}))
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))
