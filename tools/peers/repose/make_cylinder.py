"""Writes cylinder.stl: an open cylinder (no caps), radius 0.025 m, from z = 0 to 0.1 m, 128
facets round, normals pointing in (LIGGGHTS meshes are two-sided; the direction is for tidiness)."""
import math, sys

R, H, N = 0.025, 0.1, 128
out = open(sys.argv[1] if len(sys.argv) > 1 else "cylinder.stl", "w")
out.write("solid cylinder\n")
for k in range(N):
    a0, a1 = 2 * math.pi * k / N, 2 * math.pi * (k + 1) / N
    p = [(R * math.cos(a0), R * math.sin(a0)), (R * math.cos(a1), R * math.sin(a1))]
    am = 0.5 * (a0 + a1)
    n = (-math.cos(am), -math.sin(am), 0.0)
    quads = [((p[0], 0), (p[1], 0), (p[1], H)), ((p[0], 0), (p[1], H), (p[0], H))]
    for tri in quads:
        out.write(f"facet normal {n[0]:.6e} {n[1]:.6e} {n[2]:.6e}\nouter loop\n")
        for (x, y), z in tri:
            out.write(f"vertex {x:.9e} {y:.9e} {z:.9e}\n")
        out.write("endloop\nendfacet\n")
out.write("endsolid cylinder\n")
