#!/usr/bin/env python3
"""Prints the include graph of a source tree and fails on a circle.

Two levels, each checked for circles:
  files: an arrow a -> b when a.cc or a.h includes b.h (b's .cc is taken as one node with it,
         so "contact.cc needs space_switch.h and space_switch.cc needs contact.h" is a circle);
  rooms: an arrow between the folders directly under ROOT (precompute/'s space/, solvers/, ...)
         when a file of one includes a header of the other.

Only quoted includes ("name.h" or "room/name.h") that resolve inside ROOT count; system and
third-party headers (<...>) and headers of other trees (mrt/, meshing/) are outside the graph.

  scripts/include_graph.py precompute            # rooms and files of the precompute
  scripts/include_graph.py realtime/src --quiet  # only the verdict (exit 1 on a circle)
"""
import argparse
import os
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
SOURCE_SUFFIXES = (".h", ".hpp", ".cc", ".cpp", ".c")


def source_files(root):
    for folder, _, names in os.walk(root):
        for name in sorted(names):
            if name.endswith(SOURCE_SUFFIXES):
                yield os.path.relpath(os.path.join(folder, name), root)


def node_of(path):
    """A header and its implementation are one node: 'space/far_field'."""
    return os.path.splitext(path)[0]


def resolve(include, including_file, known):
    """The tree-relative path an include names, or None when it is outside the tree."""
    beside = os.path.normpath(os.path.join(os.path.dirname(including_file), include))
    for candidate in (beside, os.path.normpath(include)):
        if candidate in known:
            return candidate
    return None


def file_graph(root):
    files = list(source_files(root))
    known = set(files)
    graph = {node_of(f): set() for f in files}
    for f in files:
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as stream:
            text = stream.read()
        for include in INCLUDE.findall(text):
            target = resolve(include, f, known)
            if target is not None and node_of(target) != node_of(f):
                graph[node_of(f)].add(node_of(target))
    return graph


def room_of(node):
    return node.split(os.sep)[0] if os.sep in node else "."


def room_graph(graph):
    rooms = {}
    for node, targets in graph.items():
        rooms.setdefault(room_of(node), set())
        for target in targets:
            if room_of(target) != room_of(node):
                rooms[room_of(node)].add(room_of(target))
    return rooms


def circles(graph):
    """Every strongly connected component of more than one node (Tarjan), sorted."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    counter = [0]

    def visit(node):
        index[node] = low[node] = counter[0]
        counter[0] += 1
        stack.append(node)
        on_stack.add(node)
        for target in sorted(graph.get(node, ())):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(10000)
    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(found)


def print_graph(title, graph):
    print(f"== {title}: {sum(len(t) for t in graph.values())} arrows between {len(graph)} nodes")
    for node in sorted(graph):
        if graph[node]:
            print(f"  {node} -> {', '.join(sorted(graph[node]))}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("root", help="the tree to read, e.g. precompute or realtime/src")
    parser.add_argument("--quiet", action="store_true", help="print only the circles and the verdict")
    args = parser.parse_args()
    if not os.path.isdir(args.root):
        sys.exit(f"include_graph.py: '{args.root}' is not a folder")

    files = file_graph(args.root)
    levels = [("files", files)]
    rooms = room_graph(files)
    if len(rooms) > 1:
        levels.insert(0, ("rooms", rooms))

    failed = False
    for title, graph in levels:
        if not args.quiet:
            print_graph(f"{args.root} {title}", graph)
        for circle in circles(graph):
            failed = True
            print(f"circle among {title} of {args.root}: {' <-> '.join(circle)}")
    print(f"{args.root}: {'circles found' if failed else 'no circle'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
