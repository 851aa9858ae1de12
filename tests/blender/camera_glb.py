# Exports a glb with a mesh and a camera from Blender (headless), for tests/blender.rs:
# blender -b --factory-startup --python camera_glb.py -- OUT.glb
# Prints the camera as glTF sees it (Y up: glTF (x, y, z) = Blender (x, z, -y)):
# CAMERA px py pz fx fy fz ux uy uz yfov width height
import math
import sys

import bpy
from mathutils import Vector

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0.0, 0.0, 0.0))
bpy.ops.object.camera_add(location=(3.0, -4.0, 2.0))
cam = bpy.context.object
# Point it at the origin (its local -Z), Blender's up (+Z) kept up.
direction = Vector((0.0, 0.0, 0.0)) - cam.location
cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
cam.data.sensor_fit = "VERTICAL"
cam.data.angle_y = math.radians(40.0)
scene = bpy.context.scene
scene.camera = cam
scene.render.resolution_x = 640
scene.render.resolution_y = 480
bpy.context.view_layer.update()
bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_cameras=True)

m = cam.matrix_world
pos = m.translation
forward = -(m.to_3x3() @ Vector((0.0, 0.0, 1.0)))
up = m.to_3x3() @ Vector((0.0, 1.0, 0.0))


def gl(v):
    return (v.x, v.z, -v.y)


values = [*gl(pos), *gl(forward.normalized()), *gl(up.normalized()), cam.data.angle_y, 640, 480]
print("CAMERA " + " ".join(repr(float(x)) for x in values))
