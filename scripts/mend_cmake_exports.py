"""Mend the CMake exports of the ROS 2 PyPI wheels so a rosidl build finds this interpreter.

The wheels' exported targets (<prefix>/share/*/cmake/*Export.cmake) name the include and numpy
directories of the machine they were built on (/opt/python/cp3XX-cp3XX/...), which CMake refuses as
non-existent. This rewrites those prefixes to the running interpreter's include directory and this
environment's site-packages. Idempotent: a mended file no longer matches and is left alone.

Usage: python mend_cmake_exports.py [PREFIX]   (PREFIX defaults to sys.prefix, the venv)
"""

import pathlib
import re
import sys
import sysconfig

BUILD_MACHINE_INCLUDE = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
BUILD_MACHINE_SITE = re.compile(r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages")


def mend(prefix: pathlib.Path) -> int:
    """Rewrite every export file under prefix/share; returns how many files changed."""
    include_dir = sysconfig.get_paths()["include"]
    site_dir = sysconfig.get_paths(vars={"base": str(prefix), "platbase": str(prefix)})["purelib"]
    changed = 0
    for path in sorted((prefix / "share").glob("*/cmake/*Export.cmake")):
        text = path.read_text()
        mended = BUILD_MACHINE_SITE.sub(site_dir, BUILD_MACHINE_INCLUDE.sub(include_dir, text))
        if mended != text:
            path.write_text(mended)
            changed += 1
    return changed


if __name__ == "__main__":
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else sys.prefix).resolve()
    print(f"mend_cmake_exports: {mend(root)} export file(s) mended under {root}/share")
