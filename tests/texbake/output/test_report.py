"""The report's versions (output/report.py): the libraries, and how the kernels were built."""

import re
from importlib import metadata

from texbake.output.report import library_versions


def test_the_versions_name_the_libraries_and_the_kernels_build():
    versions = library_versions()
    assert versions["numpy"] == metadata.version("numpy") and "numba" not in versions
    # the compiled kernels' compiler and flags: the images depend on them
    assert re.fullmatch(r"(gcc|clang) \d+\.\d+\S*.*, .*-O3.* -ffp-contract=off.* \(\w+, nanobind \d+\.\d+\.\d+\)",
                        versions["kernels"]), versions["kernels"]
