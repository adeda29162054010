"""texbake.atlas as the rest of the house sees it: the names its ``__init__`` gives, and
an import light enough for the xatlas worker, which imports the package too."""

import subprocess
import sys

import pytest

import texbake.atlas


def test_the_package_names_resolve_to_their_modules():
    from texbake.atlas import cache, charts, decide, pack, uvcheck

    homes = {"Atlas": decide, "make_atlas": decide, "AtlasCache": cache, "atlas_key": cache, "uv_problem": uvcheck,
             "atlas_stats": uvcheck, "overlap": uvcheck, "run_xatlas_in_child": pack, "Sides": charts, "udim_tiles": uvcheck,
             "udim_offset": uvcheck}
    assert sorted(texbake.atlas.__all__) == sorted(homes)
    for name, module in homes.items():
        assert getattr(texbake.atlas, name) is getattr(module, name)
    with pytest.raises(AttributeError, match="unwrap"):
        texbake.atlas.unwrap  # noqa: B018 - the folder's own, not named by the package


def test_the_worker_imports_no_heavy_library():
    code = ("import sys, texbake.atlas.packworker; "
            "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'scipy', 'trimesh', 'OpenImageIO', 'pydantic'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""
