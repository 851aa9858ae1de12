# Writes a COLMAP model with pycolmap (PyPI), as text and as binary, for tests/cameras.rs:
# python write_model.py OUT_DIR
# OUT_DIR/txt and OUT_DIR/bin get cameras, images (and pycolmap's rigs, frames, points3D).
# Prints one line per image, in name order: EXPECT name width height fx fy cx cy, the
# projection centre (3), the world-to-camera rotation (9, row major), and the pixel (u, v)
# that pycolmap projects the world point (0.3, -0.2, 0.5) to (COLMAP's convention: pixel
# centres at + 0.5).
import os
import sys

import numpy as np
import pycolmap

out = sys.argv[1]
rec = pycolmap.Reconstruction()
rec.add_camera_with_trivial_rig(
    pycolmap.Camera(model="PINHOLE", width=64, height=48, params=[50.0, 52.0, 30.5, 22.25], camera_id=1)
)
rec.add_camera_with_trivial_rig(
    pycolmap.Camera(model="SIMPLE_PINHOLE", width=80, height=60, params=[70.0, 41.0, 28.0], camera_id=2)
)
poses = [
    ("view_b.png", 1, [0.1, 0.2, 0.3, 0.927], [0.5, -0.2, 3.0]),
    ("view_a.png", 2, [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 2.0]),
    ("view c.png", 1, [-0.3, 0.1, 0.05, 0.95], [-0.4, 0.1, 2.5]),
]
for k, (name, cam, xyzw, t) in enumerate(poses):
    q = np.array(xyzw) / np.linalg.norm(xyzw)
    image = pycolmap.Image(name=name, camera_id=cam, image_id=k + 1)
    rec.add_image_with_trivial_frame(image, pycolmap.Rigid3d(pycolmap.Rotation3d(q), np.array(t)))
for d in ("txt", "bin"):
    os.makedirs(os.path.join(out, d), exist_ok=True)
rec.write_text(os.path.join(out, "txt"))
rec.write_binary(os.path.join(out, "bin"))
point = np.array([0.3, -0.2, 0.5])
for image in sorted(rec.images.values(), key=lambda i: i.name):
    cam = rec.cameras[image.camera_id]
    cam_from_world = image.cam_from_world()
    uv = cam.img_from_cam(cam_from_world * point)
    values = [
        cam.width, cam.height, cam.focal_length_x, cam.focal_length_y,
        cam.principal_point_x, cam.principal_point_y,
        *image.projection_center(), *cam_from_world.rotation.matrix().flatten(), *uv,
    ]
    print("EXPECT", image.name.replace(" ", "_"), " ".join(repr(float(v)) for v in values))
