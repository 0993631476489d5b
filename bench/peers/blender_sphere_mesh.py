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
import struct
import sys

import bpy

out_path = sys.argv[sys.argv.index("--") + 1]

for item in list(bpy.data.objects):
    bpy.data.objects.remove(item)
bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0.0, 0.0, 0.0), calc_uvs=True)
obj = bpy.context.object
for polygon in obj.data.polygons:
    polygon.use_smooth = True
modifier = obj.modifiers.new(name="Subsurf", type="SUBSURF")
modifier.levels = 1
modifier.render_levels = 1
modifier.subdivision_type = "CATMULL_CLARK"

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
