# The lighting-estimation protocol's sphere scene (DiffusionLight/DiffusionLight-evaluation,
# stylelight/{mirror,matte_silver,diffuse}.py), built from its documented parameters by hdrflow's
# own code, so that the peer runs where the protocol's checkout cannot be fetched (CI):
#
#   blender --background --factory-startup --python bench/peers/blender_protocol_scene.py -- \
#       MAP.exr OUT_DIR PERCENT SAMPLES SEEDS MATERIALS
#
# SEEDS and MATERIALS are comma-separated (e.g. `0,1` and `mirror,matte_silver,diffuse`). Writes
# OUT_DIR/seed<S>/<material>.exr for each and prints one line per render with its wall time.
#
# The scene, as the protocol's scripts and their `utils` make it (docs/src/guides/
# evaluation-protocol.md gives each parameter's source; tests/probe_blender.rs checks this script
# against hdrflow's ProbeSphere, and bench/peers/blender_probe.sh runs the protocol's own scripts):
# - a UV sphere of radius 1 (Blender's default 32 segments, 16 rings), smooth shading, a
#   Catmull-Clark subdivision surface of level 1;
# - a camera at (0, -16, 2) tracking it (-Z to the target, Y up), 85 mm lens, 36 x 24 mm sensor fit
#   horizontally, depth of field focused on the sphere at f/0.5 with 11 blades;
# - 1920 x 1080 at PERCENT, Cycles, SAMPLES samples, adaptive sampling off, transparent film,
#   OpenEXR output; the world's Background colour from an Environment Texture of MAP through the
#   Generated coordinates and a Mapping node of zero rotation;
# - the materials: Principled BSDFs with the protocol's `set_principled_node` defaults and
#   mirror (base 0.8, metallic 1, specular 0.2, roughness 0), matte silver (base 0.8, metallic 1,
#   specular 0, roughness 0.3271; its Glossy, Fresnel and Mix nodes are made but, as in the
#   protocol, not linked to the output) and diffuse (base 0.8, metallic 0, specular 0.5,
#   roughness 0.364).
# Changed, as bench/peers/blender_probe_setup.py changes the protocol's own scripts: the CPU
# renders (the protocol asks for CUDA), without the denoiser (Debian's Blender is built without
# OpenImageDenoise), with `cycles.seed` set so that two seeds differ by noise alone.
import os
import sys
import time

import bpy

MATERIALS = {
    "mirror": dict(base_color=(0.8, 0.8, 0.8, 1.0), metallic=1.0, specular=0.2, roughness=0.0),
    "matte_silver": dict(base_color=(0.8, 0.8, 0.8, 1.0), metallic=1.0, specular=0.0, roughness=0.3271),
    "diffuse": dict(base_color=(0.8, 0.8, 0.8, 1.0), metallic=0.0, specular=0.5, roughness=0.364),
}


def usage(message):
    sys.stderr.write("blender_protocol_scene: %s\n" % message)
    sys.stderr.write("usage: blender --background --factory-startup --python blender_protocol_scene.py -- "
                     "MAP.exr OUT_DIR PERCENT SAMPLES SEEDS MATERIALS\n")
    sys.exit(2)


def set_principled(node, base_color, metallic, specular, roughness):
    """The protocol's `utils.set_principled_node`: its defaults, then the material's four values."""
    defaults = {
        "Subsurface": 0.0,
        "Subsurface Color": (0.8, 0.8, 0.8, 1.0),
        "Subsurface Radius": (1.0, 0.2, 0.1),
        "Specular Tint": 0.0,
        "Anisotropic": 0.0,
        "Anisotropic Rotation": 0.0,
        "Sheen": 0.0,
        "Sheen Tint": 0.5,
        "Clearcoat": 0.0,
        "Clearcoat Roughness": 0.03,
        "IOR": 1.45,
        "Transmission": 0.0,
        "Transmission Roughness": 0.0,
    }
    for name, value in defaults.items():
        node.inputs[name].default_value = value
    node.inputs["Base Color"].default_value = base_color
    node.inputs["Metallic"].default_value = metallic
    node.inputs["Specular"].default_value = specular
    node.inputs["Roughness"].default_value = roughness


def protocol_sphere():
    """The protocol's `utils.create_smooth_sphere()`, alone in the scene: every object removed, a
    UV sphere of radius 1 with smooth shading and a level-1 Catmull-Clark subdivision surface
    (also what blender_sphere_mesh.py dumps for ProbeSphere)."""
    for item in list(bpy.data.objects):
        bpy.data.objects.remove(item)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0.0, 0.0, 0.0), calc_uvs=True)
    sphere = bpy.context.object
    for polygon in sphere.data.polygons:
        polygon.use_smooth = True
    subsurf = sphere.modifiers.new(name="Subsurf", type="SUBSURF")
    subsurf.levels = 1
    subsurf.render_levels = 1
    subsurf.subdivision_type = "CATMULL_CLARK"
    return sphere


def build_scene(scene, map_path, material, percent, samples):
    sphere = protocol_sphere()

    mat = bpy.data.materials.new("protocol_" + material)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    for node in list(nodes):
        nodes.remove(node)
    output = nodes.new(type="ShaderNodeOutputMaterial")
    principled = nodes.new(type="ShaderNodeBsdfPrincipled")
    set_principled(principled, **MATERIALS[material])
    links.new(principled.outputs["BSDF"], output.inputs["Surface"])
    if material == "matte_silver":
        # As in matte_silver.py: a Glossy (0.369), a Fresnel (IOR 6.55) and a Mix Shader fed by
        # them and the Principled BSDF, whose output reaches nothing.
        glossy = nodes.new(type="ShaderNodeBsdfGlossy")
        glossy.inputs["Roughness"].default_value = 0.369
        mix = nodes.new(type="ShaderNodeMixShader")
        fresnel = nodes.new(type="ShaderNodeFresnel")
        fresnel.inputs["IOR"].default_value = 6.550
        links.new(principled.outputs["BSDF"], mix.inputs[1])
        links.new(glossy.outputs["BSDF"], mix.inputs[2])
        links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
    sphere.data.materials.append(mat)

    bpy.ops.object.camera_add(location=(0.0, -16.0, 2.0))
    camera_object = bpy.context.object
    track = camera_object.constraints.new(type="TRACK_TO")
    track.target = sphere
    track.track_axis = "TRACK_NEGATIVE_Z"
    track.up_axis = "UP_Y"
    camera = camera_object.data
    camera.sensor_fit = "HORIZONTAL"
    camera.sensor_width = 36.0
    camera.sensor_height = 24.0
    camera.lens = 85.0
    camera.dof.use_dof = True
    camera.dof.focus_object = sphere
    camera.dof.aperture_fstop = 0.5
    camera.dof.aperture_blades = 11

    scene.render.resolution_percentage = percent
    scene.render.resolution_x = 1920
    scene.render.resolution_y = 1080
    scene.camera = camera_object
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.engine = "CYCLES"
    scene.render.use_motion_blur = False
    scene.render.film_transparent = True
    scene.view_layers[0].cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.samples = samples
    scene.cycles.device = "CPU"

    world = scene.world
    world.use_nodes = True
    tree = world.node_tree
    texture = tree.nodes.new(type="ShaderNodeTexEnvironment")
    texture.image = bpy.data.images.load(os.path.abspath(map_path), check_existing=True)
    mapping = tree.nodes.new(type="ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.0)
    coords = tree.nodes.new(type="ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    tree.links.new(texture.outputs["Color"], tree.nodes["Background"].inputs["Color"])


def main():
    if "--" not in sys.argv:
        usage("no arguments after --")
    args = sys.argv[sys.argv.index("--") + 1:]
    if len(args) != 6:
        usage("expected 6 arguments, got %d" % len(args))
    map_path, out_dir, percent, samples, seeds, materials = args
    if bpy.app.version >= (4, 0, 0):
        # Blender 4 replaced the Principled BSDF (v2: "Specular" became "Specular IOR Level", the
        # sheen and coat changed): the protocol's materials, and ProbeSphere's model of them, are
        # Principled v1's, as Blender 3.x evaluates it.
        usage("the protocol's materials are Blender 3.x's Principled BSDF; this is Blender %s"
              % bpy.app.version_string)
    if not os.path.isfile(map_path):
        usage("%s: no such file" % map_path)
    try:
        percent, samples = int(percent), int(samples)
        seeds = [int(s) for s in seeds.split(",")]
    except ValueError as e:
        usage(str(e))
    materials = materials.split(",")
    for m in materials:
        if m not in MATERIALS:
            usage("material %r is not one of %s" % (m, ", ".join(MATERIALS)))
    scene = bpy.data.scenes["Scene"]
    for material in materials:
        build_scene(scene, map_path, material, percent, samples)
        for seed in seeds:
            scene.cycles.seed = seed
            folder = os.path.join(os.path.abspath(out_dir), "seed%d" % seed)
            os.makedirs(folder, exist_ok=True)
            scene.render.filepath = os.path.join(folder, material)
            start = time.time()
            bpy.ops.render.render(write_still=True)
            print("blender_protocol_scene: %s seed %d: %.2f s (Blender %s)"
                  % (material, seed, time.time() - start, bpy.app.version_string))


if __name__ == "__main__":
    main()
