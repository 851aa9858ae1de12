# Blender side of tests/blender.rs: renders a rara mesh export the way a Blender user would.
# blender -b --factory-startup --python render.py -- MESH CAMERAS.json OUT.png SAMPLES
# MESH is .glb (Blender's glTF importer: COLOR_0, alpha BLEND, KHR_materials_unlit), .obj or
# .ply (vertex colours as emission, opaque: neither format carries alpha Blender reads).
# The camera is the first of an INRIA cameras.json (columns of `rotation`: right, down,
# forward; Blender's camera looks down its -Z with +Y up). Cycles on the CPU, black world,
# no display transform: the vertex colours are 3DGS's display-referred values (SPEC section 6),
# which Blender takes as linear, so they are written to the PNG as they are; and enough
# transparent bounces for the overlapping octagons.
import json
import math
import sys

import bpy
import numpy
from mathutils import Matrix

# Blender 3.4's glTF importer uses numpy.bool, which numpy 1.24 (Debian 12's) removed.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

mesh, cameras, out, samples = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
if mesh.endswith(".glb"):
    bpy.ops.import_scene.gltf(filepath=mesh)
else:
    if mesh.endswith(".obj"):
        bpy.ops.wm.obj_import(filepath=mesh, forward_axis='Y', up_axis='Z')
    else:
        bpy.ops.import_mesh.ply(filepath=mesh)
    obj = bpy.context.selected_objects[0]
    material = bpy.data.materials.new("radiance")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    colour = nodes.new("ShaderNodeVertexColor")
    colour.layer_name = obj.data.color_attributes[0].name if obj.data.color_attributes else ""
    emission = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(colour.outputs["Color"], emission.inputs["Color"])
    material.node_tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    obj.data.materials.clear()
    obj.data.materials.append(material)
objects = [o for o in scene.objects if o.type == 'MESH']
print("RARA_BLENDER meshes", len(objects), "vertices", sum(len(o.data.vertices) for o in objects),
      "faces", sum(len(o.data.polygons) for o in objects))

cam = json.load(open(cameras))[0]
w, h = cam["width"], cam["height"]
rot = cam["rotation"]  # rows; columns are right, down, forward
right = [rot[r][0] for r in range(3)]
down = [rot[r][1] for r in range(3)]
forward = [rot[r][2] for r in range(3)]
m = Matrix.Identity(4)
for r in range(3):
    m[r][0], m[r][1], m[r][2], m[r][3] = right[r], -down[r], -forward[r], cam["position"][r]
if mesh.endswith(".glb"):
    # The glTF importer turns glTF's +Y up into Blender's +Z up, (x, y, z) -> (x, -z, y); rara
    # writes its own coordinates unconverted, so the camera turns with them.
    m = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1))) @ m
camera_data = bpy.data.cameras.new("rara")
camera_data.sensor_fit = 'HORIZONTAL'
camera_data.angle_x = 2.0 * math.atan(w / (2.0 * cam["fx"]))
camera_data.clip_start = 0.2
camera = bpy.data.objects.new("rara", camera_data)
camera.matrix_world = m
scene.collection.objects.link(camera)
scene.camera = camera

world = bpy.data.worlds.new("black")
world.color = (0.0, 0.0, 0.0)
scene.world = world
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = int(samples)
scene.cycles.use_denoising = False
scene.cycles.transparent_max_bounces = 1024
scene.cycles.max_bounces = 1024
scene.render.resolution_x = w
scene.render.resolution_y = h
scene.render.resolution_percentage = 100
scene.render.film_transparent = False
scene.display_settings.display_device = 'None'
scene.render.image_settings.file_format = 'PNG'
scene.render.image_settings.color_mode = 'RGBA'
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
