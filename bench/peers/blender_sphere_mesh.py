# Dumps the sphere the lighting-estimation protocol renders, as Blender evaluates it, to the binary file
# `ProbeSphere(shape: Subdivided)` reads (src/maths/render/probe_sphere/sphere_mesh.bin).
#
#   blender --background --factory-startup --python bench/peers/blender_sphere_mesh.py -- OUT.bin
#
# The sphere is built as DiffusionLight-evaluation's stylelight/utils/mesh.py `create_smooth_sphere`
# builds it: `primitive_uv_sphere_add(radius=1)` (32 segments, 16 rings), every face smooth, a
# Subdivision Surface modifier of level 1 (viewport and render), Catmull-Clark, the modifier's other
# settings at their defaults (limit surface on). The evaluated mesh is what Cycles receives: its
# vertex positions, its vertex normals (what smooth shading interpolates) and its loop triangles.
#
# Format, little-endian: b"HFSPHERE", u32 vertex count, u32 triangle count, then per vertex six f32
# (x, y, z, nx, ny, nz; Blender world coordinates, Z up), then per triangle three u32 vertex indices
# in Blender's loop-triangle order. Made with Debian's Blender 3.4.1.
# Blender evaluates the modifier on several threads: two runs list the vertices in other orders and
# their normals differ by up to 3.3e-6 (2026-12-07), the same sphere, so the file is not bit-reproducible.
import os
import struct
import sys

import bpy

out_path = sys.argv[sys.argv.index("--") + 1]

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_protocol_scene import protocol_sphere  # noqa: E402

obj = protocol_sphere()

depsgraph = bpy.context.evaluated_depsgraph_get()
mesh = obj.evaluated_get(depsgraph).to_mesh()
mesh.calc_loop_triangles()
assert all(t.use_smooth for t in mesh.loop_triangles)

with open(out_path, "wb") as f:
    f.write(b"HFSPHERE")
    f.write(struct.pack("<II", len(mesh.vertices), len(mesh.loop_triangles)))
    for v in mesh.vertices:
        f.write(struct.pack("<6f", *v.co, *v.normal))
    for t in mesh.loop_triangles:
        f.write(struct.pack("<3I", *t.vertices))
print("wrote", out_path, len(mesh.vertices), "vertices", len(mesh.loop_triangles), "triangles",
      "Blender", bpy.app.version_string)
