#!/usr/bin/env python3
"""The include rules of the tree, checked (issue 32).

Top level (README.md, "Layout"): server -> api -> warp -> tiles. A file under one of these folders
includes project headers from its own folder or from those after it in that order, never before.
Inside warp/, warp/README.md's table says which of warp's folders each folder may include: its
"includes" column names them ("-" none, "all of the above" every folder listed before it). A
method's sub-folder (warp/methods/mp/) is its folder's (methods).

  include_rules_test.py [--root DIR]    check the tree; exit 1 listing every include that breaks a rule
  include_rules_test.py --self-test     also plant a forbidden include of each kind in a copy of the
                                        rules and show that it is caught (what CTest runs)
"""
import argparse
import pathlib
import re
import shutil
import sys
import tempfile

TOP_ORDER = ["server", "api", "warp", "tiles"]  # each may include itself and those after it
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
SOURCES = (".h", ".cc")


def warp_rules(readme: pathlib.Path):
    """warp/README.md's table: folder -> the warp folders it may include (itself too)."""
    rows = re.findall(r"^\|\s*`([a-z_]+)/`\s*\|[^|]*\|\s*([^|]+?)\s*\|\s*$", readme.read_text(), re.M)
    if not rows:
        raise SystemExit(f"{readme}: no folder table found")
    rules, seen = {}, []
    for folder, includes in rows:
        if includes in ("—", "-"):
            allowed = set()
        elif includes == "all of the above":
            allowed = set(seen)
        else:
            allowed = {name.strip() for name in includes.split(",")}
            unknown = allowed - set(seen)
            if unknown:
                raise SystemExit(f"{readme}: {folder}/ may include {sorted(unknown)}, not listed above it")
        rules[folder] = allowed | {folder}
        seen.append(folder)
    return rules


def violations(root: pathlib.Path):
    rules = warp_rules(root / "warp" / "README.md")
    found = []
    for top in TOP_ORDER:
        may = set(TOP_ORDER[TOP_ORDER.index(top):])
        for path in sorted((root / top).rglob("*")):
            if path.suffix not in SOURCES or not path.is_file():
                continue
            rel = path.relative_to(root)
            for header in INCLUDE.findall(path.read_text(errors="replace")):
                parts = header.split("/")
                if len(parts) < 2 or parts[0] not in TOP_ORDER:
                    continue  # a system or generated header
                if parts[0] not in may:
                    found.append(f"{rel}: includes {header} ({top}/ may include {', '.join(sorted(may))})")
                elif top == "warp" and parts[0] == "warp":
                    own, their = rel.parts[1], parts[1]
                    if own not in rules:
                        found.append(f"{rel}: warp/{own}/ is not in warp/README.md's table")
                    elif their not in rules[own]:
                        found.append(f"{rel}: includes {header} (warp/README.md: {own}/ may include "
                                     f"{', '.join(sorted(rules[own] - {own})) or 'none of warp'})")
    return found


def self_test(root: pathlib.Path):
    """Plants one forbidden include of each kind in a copy of the rules and the files that carry them."""
    plants = [
        ("tiles/planted.cc", '#include "api/router.h"\n', "tiles/ may include"),
        ("warp/core/planted.h", '#include "warp/icaz/icaz.h"\n', "core/ may include none of warp"),
        ("warp/meshing/planted.cc", '#include "warp/saliency/significance.h"\n', "meshing/ may include core"),
    ]
    for name, text, expected in plants:
        with tempfile.TemporaryDirectory() as tmp:
            copy = pathlib.Path(tmp)
            (copy / "warp").mkdir()
            shutil.copy(root / "warp" / "README.md", copy / "warp" / "README.md")
            for top in TOP_ORDER:
                (copy / top).mkdir(exist_ok=True)
            (copy / name).parent.mkdir(parents=True, exist_ok=True)
            (copy / name).write_text(text)
            caught = violations(copy)
            if len(caught) != 1 or expected not in caught[0]:
                raise SystemExit(f"self-test: the planted {name} ({text.strip()}) gave {caught}, not one '{expected}'")
            print(f"self-test: planted {name}: {caught[0]}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", default=str(pathlib.Path(__file__).resolve().parents[2]))
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    root = pathlib.Path(args.root)
    if args.self_test:
        self_test(root)
    found = violations(root)
    for v in found:
        print(v)
    print(f"{len(found)} include{'s' if len(found) != 1 else ''} breaking a rule")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
