#!/usr/bin/python3
"""HeaderLayout: lib/mps's folders form layers (docs/library.md, "Public headers"): a file includes only headers of
its own folder and of the folders below it in LAYERS, so no two folders include each other and no header cycle can
form. Also: every file lives in one of these folders, and no header includes itself through another (a cycle within
a folder). Exit 1 listing every include that breaks a rule.
"""
import re
import sys
from pathlib import Path

LAYERS = ["core", "solvers", "numerics", "boundaries", "step", "solids", "acoustics", "parallel", "io"]
ROOT = Path(__file__).resolve().parent.parent / "lib" / "mps"
INCLUDE = re.compile(r'^#include "mps/([a-z_]+)/([a-z_]+\.hpp)"', re.M)


def main():
    problems = []
    graph = {}
    for path in sorted(ROOT.rglob("*.[ch]pp")):
        folder = path.parent.name
        if path.parent == ROOT or folder not in LAYERS:
            problems.append(f"{path.relative_to(ROOT)}: not in one of the folders {', '.join(LAYERS)}")
            continue
        rank = LAYERS.index(folder)
        deps = []
        for target, header in INCLUDE.findall(path.read_text()):
            if target not in LAYERS:
                problems.append(f"{path.relative_to(ROOT)} includes mps/{target}/{header}: no such folder")
            elif LAYERS.index(target) > rank:
                problems.append(f"{path.relative_to(ROOT)} ({folder}) includes mps/{target}/{header}, a folder above it")
            deps.append(f"{target}/{header}")
        if path.suffix == ".hpp":
            graph[f"{folder}/{path.name}"] = deps
    # A cycle among headers: depth-first search with the path on a stack.
    state = {}

    def visit(node, stack):
        state[node] = "open"
        for dep in graph.get(node, []):
            if state.get(dep) == "open":
                problems.append("header cycle: " + " -> ".join(stack[stack.index(dep):] + [dep]))
            elif dep not in state:
                visit(dep, stack + [dep])
        state[node] = "done"

    for node in graph:
        if node not in state:
            visit(node, [node])
    checked = sum(1 for _ in ROOT.rglob("*.[ch]pp"))
    if problems:
        print("\n".join(problems))
        return 1
    print(f"{checked} files in {len(LAYERS)} folders: every include goes to its own folder or one below; no cycle")
    return 0


if __name__ == "__main__":
    sys.exit(main())
