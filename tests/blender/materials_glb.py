# Makes a glb of meshes with glTF materials from Blender (headless), for tests/blender.rs and
# examples/scenes/materials_plant.json (scripts/blender_assets.sh):
# blender -b --factory-startup --python materials_glb.py -- OUT.glb [SUBDIVISIONS]
#
# In Blender's frame (Z up; glTF (x, y, z) = Blender (x, z, -y)):
# - "Canvas": a 2 x 2 plane standing at (0, 3, 1.2) behind the others, facing -Y (the default
#   plane turned 90 degrees about X), Blender's default UVs, an image texture of four flat
#   quadrants seen from the front: top left red, top right green, bottom left blue, bottom
#   right sRGB grey 128 (linear 0.216). Diffuse.
# - "Monkey": Suzanne at (0, 0, 1), subdivided SUBDIVISIONS times (4: about 250k triangles),
#   smooth, UVs by smart projection, a striped image texture times a base colour. Diffuse.
# - "Glass": a sphere of radius 0.6 at (-1.8, -0.6, 0.6), transmission 1, IOR 1.45.
# - "Gold": a sphere of radius 0.6 at (1.8, -0.6, 0.6), metallic 1, roughness 0, base colour
#   gold.
# - "Lamp": a cube of side 0.4 at (0, -1.6, 0.2), dark grey, emitting orange at strength 3.
# Prints TRIANGLES n: the triangles it exported.
import math
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1 :]
out = args[0]
levels = int(args[1]) if len(args) > 1 else 4
bpy.ops.wm.read_factory_settings(use_empty=True)


def principled(name):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    return m, m.node_tree.nodes["Principled BSDF"]


def image(name, size, colour_at):
    # A byte image: its pixels are the sRGB-encoded values over 255, bottom row first.
    img = bpy.data.images.new(name, size, size, alpha=False)
    px = []
    for j in range(size):
        for i in range(size):
            px.extend(colour_at(i, j))
    img.pixels[:] = px
    img.file_format = "PNG"
    img.pack()
    return img


def textured(name, img, factor=(1.0, 1.0, 1.0, 1.0)):
    m, bsdf = principled(name)
    tex = m.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = "Linear"
    if factor == (1.0, 1.0, 1.0, 1.0):
        m.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    else:
        mul = m.node_tree.nodes.new("ShaderNodeMix")
        mul.data_type = "RGBA"
        mul.blend_type = "MULTIPLY"
        mul.inputs["Factor"].default_value = 1.0
        m.node_tree.links.new(tex.outputs["Color"], mul.inputs[6])
        mul.inputs[7].default_value = factor
        m.node_tree.links.new(mul.outputs[2], bsdf.inputs["Base Color"])
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 0.8
    return m


def quadrant(i, j, n=64):
    top, right = j >= n // 2, i >= n // 2
    if top and not right:
        return (1.0, 0.0, 0.0, 1.0)
    if top and right:
        return (0.0, 1.0, 0.0, 1.0)
    if not right:
        return (0.0, 0.0, 1.0, 1.0)
    return (128 / 255, 128 / 255, 128 / 255, 1.0)


def stripes(i, j):
    k = (i // 64 + j // 64) % 3
    return [(0.9, 0.35, 0.1, 1.0), (0.95, 0.9, 0.8, 1.0), (0.15, 0.35, 0.75, 1.0)][k]


bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, 3.0, 1.2), rotation=(math.pi / 2, 0.0, 0.0))
canvas = bpy.context.object
canvas.name = "Canvas"
canvas.data.materials.append(textured("Quadrants", image("quadrants", 64, quadrant)))

bpy.ops.mesh.primitive_monkey_add(size=1.6, location=(0.0, 0.0, 1.0))
monkey = bpy.context.object
monkey.name = "Monkey"
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.select_all(action="SELECT")
bpy.ops.uv.smart_project()
bpy.ops.object.mode_set(mode="OBJECT")
if levels > 0:
    sub = monkey.modifiers.new("subdivision", "SUBSURF")
    sub.levels = levels
    sub.render_levels = levels
    bpy.ops.object.modifier_apply(modifier=sub.name)
bpy.ops.object.shade_smooth()
monkey.data.materials.append(
    textured("Painted", image("stripes", 256, stripes), factor=(1.0, 0.9, 0.8, 1.0))
)

bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, segments=64, ring_count=32, location=(-1.8, -0.6, 0.6))
glass = bpy.context.object
glass.name = "Glass"
bpy.ops.object.shade_smooth()
m, bsdf = principled("Glass")
bsdf.inputs["Transmission"].default_value = 1.0
bsdf.inputs["IOR"].default_value = 1.45
bsdf.inputs["Roughness"].default_value = 0.0
glass.data.materials.append(m)

bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, segments=64, ring_count=32, location=(1.8, -0.6, 0.6))
gold = bpy.context.object
gold.name = "Gold"
bpy.ops.object.shade_smooth()
m, bsdf = principled("Gold")
bsdf.inputs["Base Color"].default_value = (1.0, 0.766, 0.336, 1.0)
bsdf.inputs["Metallic"].default_value = 1.0
bsdf.inputs["Roughness"].default_value = 0.0
gold.data.materials.append(m)

bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.0, -1.6, 0.2))
lamp = bpy.context.object
lamp.name = "Lamp"
m, bsdf = principled("Lamp")
bsdf.inputs["Base Color"].default_value = (0.05, 0.05, 0.05, 1.0)
bsdf.inputs["Emission"].default_value = (1.0, 0.5, 0.1, 1.0)
bsdf.inputs["Emission Strength"].default_value = 3.0
lamp.data.materials.append(m)

bpy.context.view_layer.update()
triangles = 0
for ob in bpy.context.scene.objects:
    if ob.type == "MESH":
        ob.data.calc_loop_triangles()
        triangles += len(ob.data.loop_triangles)
bpy.ops.export_scene.gltf(filepath=out, export_format="GLB")
print(f"TRIANGLES {triangles}")
