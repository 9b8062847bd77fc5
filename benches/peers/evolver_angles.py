#!/usr/bin/env python3
"""Triangle quality of Surface Evolver datafiles and dumps (benches/peers/evolver_compare.sh).

Usage: evolver_angles.py FILE [FILE ...]

Reads each file's `vertices` (id x y z ...), `edges` (id tail head ...) and `faces` / `facets`
(id and three signed edge ids, an edge loop) sections, as `evolver_export` writes them and as
Evolver's `dump` writes them, and prints one line per file: the facet count, the smallest and
the largest interior angle over all triangles (degrees) and how many triangles have an angle
below 5° or above 170°. Only triangles are read: a facet with another number of edges is an
error (exit 2), as is a file without these sections.
"""

import math
import re
import sys

SECTIONS = {"vertices", "edges", "faces", "facets", "bodies"}


def read(path):
    """Vertex coordinates by id and triangles as vertex-id triples, in edge-loop order."""
    vertices, edges, faces = {}, {}, []
    section = None
    with open(path) as text:
        for line in text:
            line = re.sub(r"/\*.*?\*/|//.*", "", line).strip()
            if not line:
                continue
            words = line.split()
            if words[0].lower() in SECTIONS:
                section = words[0].lower()
                continue
            if words[0].lower() == "read":
                break
            if section is None or not re.fullmatch(r"\d+", words[0]):
                continue
            if section == "vertices":
                vertices[int(words[0])] = tuple(float(w) for w in words[1:4])
            elif section == "edges":
                edges[int(words[0])] = (int(words[1]), int(words[2]))
            elif section in {"faces", "facets"}:
                loop = []
                for w in words[1:]:
                    if not re.fullmatch(r"-?\d+", w):
                        break
                    loop.append(int(w))
                if len(loop) != 3:
                    raise ValueError(f"facet {words[0]} has {len(loop)} edges, not 3")
                faces.append(loop)
    if not vertices or not edges or not faces:
        raise ValueError("no vertices, edges and faces sections")
    triangles = []
    for loop in faces:
        tails = [edges[e][0] if e > 0 else edges[-e][1] for e in loop]
        triangles.append(tails)
    return vertices, triangles


def angles(p, q, r):
    """The interior angles at p, q and r of triangle pqr, degrees."""
    out = []
    for a, b, c in ((p, q, r), (q, r, p), (r, p, q)):
        u = [b[i] - a[i] for i in range(3)]
        v = [c[i] - a[i] for i in range(3)]
        cross = (
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        )
        dot = sum(u[i] * v[i] for i in range(3))
        out.append(math.degrees(math.atan2(math.sqrt(sum(x * x for x in cross)), dot)))
    return out


def quality(path):
    """Facet count, smallest and largest angle (degrees), triangles with an angle < 5° and
    with an angle > 170°."""
    vertices, triangles = read(path)
    smallest, largest, thin, wide = 180.0, 0.0, 0, 0
    for t in triangles:
        a = angles(*(vertices[v] for v in t))
        smallest, largest = min(smallest, min(a)), max(largest, max(a))
        thin += min(a) < 5.0
        wide += max(a) > 170.0
    return len(triangles), smallest, largest, thin, wide


def describe(path):
    """One line of `quality(path)`."""
    n, smallest, largest, thin, wide = quality(path)
    return (
        f"{n} facets, angles {smallest:.4g}° … {largest:.4g}°, "
        f"{thin} with an angle < 5°, {wide} with an angle > 170°"
    )


def main():
    if len(sys.argv) < 2:
        print("usage: evolver_angles.py FILE [FILE ...]", file=sys.stderr)
        return 2
    for path in sys.argv[1:]:
        try:
            print(f"{path}: {describe(path)}")
        except (OSError, ValueError, KeyError, IndexError) as e:
            print(f"{path}: {e}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
