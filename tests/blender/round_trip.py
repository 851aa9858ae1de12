# Blender side of tests/blender.rs: a simulation-style edit of rara's OBJ export.
# blender -b --factory-startup --python round_trip.py -- IN.obj OUT.obj META.json
# Imports IN.obj with no axis conversion, rotates and moves the object, bends it with a
# Simple Deform modifier (BEND about Z, 0.8 rad over the whole mesh), exports the result with
# the modifier and the object transform applied, vertex order kept (no normals or UVs, so a
# reader that numbers vertices by first use sees the file's order), and writes the object's
# world matrix and the angle to META.json for the Rust side to apply the same transform.
import json
import sys

import bpy

src, dst, meta = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.obj_import(filepath=src, forward_axis='Y', up_axis='Z')
obj = bpy.context.selected_objects[0]
obj.rotation_euler = (0.3, 0.5, -0.2)
obj.location = (0.1, -0.2, 0.3)
bend = obj.modifiers.new("bend", 'SIMPLE_DEFORM')
bend.deform_method = 'BEND'
bend.deform_axis = 'Z'
bend.angle = 0.8
bpy.context.view_layer.update()
bpy.ops.wm.obj_export(filepath=dst, forward_axis='Y', up_axis='Z', apply_modifiers=True,
                      export_uv=False, export_normals=False, export_colors=False,
                      export_materials=False, export_triangulated_mesh=False)
with open(meta, "w") as f:
    json.dump({"vertices": len(obj.data.vertices), "faces": len(obj.data.polygons),
               "matrix_world": [list(row) for row in obj.matrix_world],
               "angle": bend.angle}, f)
