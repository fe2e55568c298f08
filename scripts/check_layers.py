#!/usr/bin/env python3
"""Fails when a library includes a header of, or links a library of, a folder
it may not depend on.

The table is docs/layout.md's (DESIGN.md section 2 as built, with
the amendments it states): a folder lists the folders it may include
from directly. Tests, benchmarks and fuzzers may include anything; no
library may include from them or from any other folder of the tree. A
library's headers under internal/ are its own (Ceres' internal/ split):
no other library and none of its public headers may include them.
"""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent

MAY_INCLUDE = {
    "base": [],
    "cluster": ["base"],
    "rt_core/model": ["base"],
    "rt_core/runtime": ["base", "rt_core/model"],
    "io_drivers": ["base", "rt_core/model", "rt_core/runtime"],
    "records": ["base", "rt_core/model", "io_drivers"],
    "hil": ["base", "rt_core/model", "rt_core/runtime", "io_drivers",
            "records"],
    "emulator": ["base", "rt_core/model", "rt_core/runtime", "io_drivers",
                 "records"],
    "estimator": ["base", "rt_core/model", "records"],
    "diagnosis": ["base", "rt_core/model", "records", "estimator"],
    "kc_sheet": ["base", "rt_core/model", "records", "estimator"],
    "designer": ["base", "rt_core/model", "records", "estimator",
                 "diagnosis"],
    "validation": ["base", "rt_core/model", "records", "estimator",
                   "diagnosis", "emulator", "hil"],
    "campaign": ["base", "rt_core/model", "records", "estimator",
                 "diagnosis", "designer"],
    "report": ["base", "rt_core/model", "records", "estimator", "diagnosis",
               "kc_sheet", "designer", "campaign"],
    "console": ["base", "rt_core/model", "rt_core/runtime", "io_drivers",
                "records", "hil"],
    "apps": ["base", "rt_core/model", "rt_core/runtime", "io_drivers",
             "records", "hil", "emulator", "estimator", "diagnosis",
             "kc_sheet", "designer", "campaign", "validation", "cluster",
             "report", "console"],
}
# records decodes logs with the DBC codec, never with a transport.
ONLY = {("records", "io_drivers"): {"can_frame.h", "dbc.h",
                                    "kc_rig_protocol.h"}}

# records links the DBC codec's library, never the transports'.
LINK_ONLY = {("records", "io_drivers"): {"kcrig_can_codec"}}

INCLUDE = re.compile(r'^\s*#\s*include\s+["<]([^">]+)[">]', re.M)


def folder_of(path):
    """The table's folder holding `path` (relative), or None."""
    for folder in sorted(MAY_INCLUDE, key=len, reverse=True):
        if path == folder or path.startswith(folder + "/"):
            return folder
    return None


def library_folders():
    """Each kcrig library (and the kcrig binary) -> the folder defining it."""
    owner = {}
    for folder in MAY_INCLUDE:
        cmake = ROOT / folder / "CMakeLists.txt"
        if cmake.is_file():
            for name in re.findall(r"add_(?:library|executable)\(\s*(kcrig\w*)",
                                   cmake.read_text(encoding="utf-8")):
                owner[name] = folder
    return owner


def check_links(errors):
    """The link lines of the library folders, against the same table."""
    owner = library_folders()
    for folder in MAY_INCLUDE:
        cmake = ROOT / folder / "CMakeLists.txt"
        if not cmake.is_file():
            continue
        text = cmake.read_text(encoding="utf-8")
        for match in re.finditer(r"target_link_libraries\(\s*(\w+)([^)]*)\)",
                                 text):
            if owner.get(match.group(1)) != folder:
                continue
            line = text.count("\n", 0, match.start()) + 1
            for linked in re.findall(r"\bkcrig_\w+", match.group(2)):
                to = owner.get(linked)
                if to is None:
                    errors.append(f"{folder}/CMakeLists.txt:{line}: "
                                  f"{linked} is no library of the table")
                    continue
                only = LINK_ONLY.get((folder, to))
                if to != folder and (to not in MAY_INCLUDE[folder] or
                                     (only and linked not in only)):
                    errors.append(f"{folder}/CMakeLists.txt:{line}: "
                                  f"{match.group(1)} may not link {linked} "
                                  f"({to})")
    return len(owner)


def main():
    errors = []
    checked = 0
    libraries = check_links(errors)
    for folder in MAY_INCLUDE:
        for source in sorted((ROOT / folder).rglob("*")):
            rel = source.relative_to(ROOT).as_posix()
            if not source.is_file() or folder_of(rel) != folder:
                continue
            if source.suffix not in (".h", ".cc", ".in"):
                continue
            checked += 1
            text = source.read_text(encoding="utf-8")
            for match in INCLUDE.finditer(text):
                target = match.group(1)
                to = folder_of(target)
                if to is None and (ROOT / target).is_file():
                    line = text.count("\n", 0, match.start()) + 1
                    errors.append(f"{rel}:{line}: {folder} may not include "
                                  f"{target} (not a library folder)")
                    continue
                line = text.count("\n", 0, match.start()) + 1
                if "/internal/" in target and (
                        to != folder or (source.suffix == ".h" and
                                         "/internal/" not in rel)):
                    errors.append(f"{rel}:{line}: {target} is internal to "
                                  f"{to}: only its own sources may include "
                                  f"it, never a public header")
                    continue
                if to is None or to == folder:
                    continue
                allowed = to in MAY_INCLUDE[folder]
                only = ONLY.get((folder, to))
                if allowed and only and pathlib.PurePath(target).name not in only:
                    allowed = False
                if not allowed:
                    errors.append(f"{rel}:{line}: {folder} may not include "
                                  f"{target} ({to})")
    for error in errors:
        print(error)
    if errors:
        print(f"layers: {len(errors)} include(s) or link(s) cross the "
              "dependency table")
        return 1
    print(f"layers: {checked} sources and the link lines of {libraries} "
          "libraries within the dependency table")
    return 0


if __name__ == "__main__":
    sys.exit(main())
