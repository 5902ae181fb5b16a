"""Imports a BVH into Blender headless and prints its bones, frames and the pelvis (or first child of the root)
height: the check that `motion-cli predict --rig CHARACTER.glb --out m.bvh` gives Blender a skeleton with the
character's own joint names. Debian's Blender 3.4 opens BVH files with the removed mode 'rU'; the patch below
drops the 'U'.

    blender -b --python examples/blender_import_bvh.py -- m.bvh
"""

import builtins
import sys

_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    return _open(file, mode.replace("U", ""), *args, **kwargs)


builtins.open = _open_without_u

import bpy  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
path = sys.argv[sys.argv.index("--") + 1]
bpy.ops.import_anim.bvh(filepath=path, global_scale=1.0, use_fps_scale=False)
armature = next(o for o in bpy.data.objects if o.type == "ARMATURE")
names = [b.name for b in armature.data.bones]
print(f"bones {len(names)}: {', '.join(names[:8])}{', ...' if len(names) > 8 else ''}")
action = armature.animation_data.action
first, last = (int(f) for f in action.frame_range)
print(f"frames {first}-{last}")
hips = armature.pose.bones[names[1] if len(names) > 1 else names[0]]
for frame in (first, (first + last) // 2, last):
    bpy.context.scene.frame_set(frame)
    x, y, z = armature.matrix_world @ hips.head
    print(f"frame {frame}: {hips.name} at ({x:.3f}, {y:.3f}, {z:.3f}) m (Blender: z up)")
