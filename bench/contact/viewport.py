# Renders baked glTF files in Blender's viewport look (Workbench, flat lighting, the file's vertex
# colours as imported by Blender's own glTF importer at its defaults), from one camera at the base
# of the Cornell box's tall block, where the floor meets it. Used by bench/contact/pictures.sh.
#
#   xvfb-run -a blender -b --factory-startup --python-exit-code 1 --python viewport.py -- OUT.png COLS A.glb [B.glb ...]
#
# Each file is rendered alone, and the renders are put into OUT.png in rows of COLS, left to right
# and top to bottom in the order given.
import os
import sys

import bpy
import numpy as np
from mathutils import Vector

if "bool" not in np.__dict__:  # Blender 3.4's glTF importer uses np.bool, removed in numpy 1.24
    np.bool = bool

args = sys.argv[sys.argv.index("--") + 1:]
out, cols, files = args[0], int(args[1]), args[2:]
W, H = 640, 480
# glTF (x, y, z) is Blender (x, -z, y). In glTF the tall block spans x 0.265-0.472, z 0.247-0.456 on
# the floor (y = 0); the camera looks from the open front, low, at its front-left base, with the
# short block's shadow on the floor between them.
eye, target = Vector((0.53, -0.06, 0.15)), Vector((0.36, -0.25, 0.0))

tiles = []
for f in files:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=f)
    scene = bpy.context.scene
    for o in list(scene.objects):
        if o.type == 'CAMERA':
            bpy.data.objects.remove(o)
    cam = bpy.data.objects.new("close_up", bpy.data.cameras.new("close_up"))
    scene.collection.objects.link(cam)
    cam.location = eye
    cam.rotation_euler = (target - eye).to_track_quat('-Z', 'Y').to_euler()
    cam.data.lens = 24
    scene.camera = cam
    scene.render.engine = 'BLENDER_WORKBENCH'
    shading = scene.display.shading
    shading.light = 'FLAT'
    shading.color_type = 'VERTEX'
    scene.view_settings.view_transform = 'Standard'  # COLOR_0 is already display-ready
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    path = os.path.splitext(out)[0] + f".{len(tiles)}.png"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    tiles.append(np.array(img.pixels[:]).reshape(H, W, 4))
    os.remove(path)

rows = (len(tiles) + cols - 1) // cols
sheet = np.ones((H * rows + 8 * (rows - 1), W * cols + 8 * (cols - 1), 4))
for k, t in enumerate(tiles):
    r, c = rows - 1 - k // cols, k % cols  # Blender's pixel rows run bottom to top
    sheet[r * (H + 8):r * (H + 8) + H, c * (W + 8):c * (W + 8) + W] = t
img = bpy.data.images.new("sheet", sheet.shape[1], sheet.shape[0], alpha=True)
img.pixels[:] = sheet.ravel()
img.filepath_raw = out
img.file_format = 'PNG'
img.save()
print(f"viewport: wrote {out} ({len(tiles)} views)")
