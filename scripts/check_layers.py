#!/usr/bin/env python3
"""Checks the layering of src/ against the README's architecture table.

The README's section "## Architecture" holds one table row per layer:
    | `layer` | what it holds | `lower`, `other` |
(the last column lists the layers it uses directly, or "—"). A file of src/LAYER/ (and of
tests/LAYER/) may include headers of LAYER and of every layer it reaches through those lists;
apps/ and bench/ may include anything. Each CMake layer target (`ridgeline_layer(NAME DEPS ...)`
in CMakeLists.txt) may link only layers the table allows it.

Exit 0 when everything holds; else one line per forbidden include or link, naming the file, the
line and the rule it breaks, and exit 1. Run from anywhere: paths are relative to the repository.
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"/]+)/')
LAYER_CALL = re.compile(r"ridgeline_layer\((\w+)(?:\s+DEPS([^)]*))?\)")


def read_table(readme):
    """Returns {layer: set of layers it uses directly} from the README's architecture table."""
    text = readme.read_text(encoding="utf-8")
    match = re.search(r"^## Architecture\n(.*?)(?=^## )", text, re.S | re.M)
    if not match:
        sys.exit(f"check_layers: {readme}: no '## Architecture' section")
    uses = {}
    for line in match.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[0].startswith("`"):
            continue
        layer = cells[0].strip("`")
        uses[layer] = set(re.findall(r"`([\w]+)`", cells[-1]))
    if not uses:
        sys.exit(f"check_layers: {readme}: the architecture table has no layer rows")
    for layer, deps in uses.items():
        unknown = deps - uses.keys()
        if unknown:
            sys.exit(f"check_layers: README: layer `{layer}` uses unknown layers {sorted(unknown)}")
    return uses


def closure(uses):
    """Every layer each layer may reach (itself included); fails on a cycle."""
    reach = {}

    def visit(layer, path):
        if layer in path:
            sys.exit("check_layers: README: the layers form a cycle: " + " -> ".join(path + [layer]))
        if layer not in reach:
            out = {layer}
            for dep in uses[layer]:
                out |= visit(dep, path + [layer])
            reach[layer] = out
        return reach[layer]

    for layer in uses:
        visit(layer, [])
    return reach


def main():
    uses = read_table(ROOT / "README.md")
    reach = closure(uses)
    problems = []

    src_layers = {p.name for p in (ROOT / "src").iterdir() if p.is_dir()}
    for missing in sorted(src_layers - uses.keys()):
        problems.append(f"src/{missing}/: a folder of src/ that the README's table does not list")

    for top in ("src", "tests"):
        for path in sorted((ROOT / top).rglob("*")):
            if path.suffix not in (".hpp", ".cpp", ".h", ".cc") or not path.is_file():
                continue
            layer = path.relative_to(ROOT / top).parts[0]
            if layer not in uses:
                continue  # tests/support and the like: helpers, not a layer
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target = m.group(1)
                if target in uses and target not in reach[layer]:
                    problems.append(
                        f"{path.relative_to(ROOT)}:{number}: includes {target}/, but `{layer}` "
                        f"may use only {', '.join(sorted(reach[layer] - {layer})) or 'nothing'}")

    cmake = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    for m in LAYER_CALL.finditer(cmake):
        layer = m.group(1)
        linked = set(re.findall(r"ridgeline_(\w+)", m.group(2) or ""))
        if layer not in uses:
            problems.append(f"CMakeLists.txt: layer target ridgeline_{layer} is not in the README's table")
            continue
        for dep in sorted(linked - reach[layer]):
            problems.append(f"CMakeLists.txt: ridgeline_{layer} links ridgeline_{dep}, which "
                            f"`{layer}` may not use")

    for p in problems:
        print(p)
    if problems:
        print(f"check_layers: {len(problems)} violation(s) of the README's architecture table")
        return 1
    print(f"check_layers: {len(uses)} layers, every include and layer link allowed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
