# Prints world positions of four bones at frames 1, 60 and 150 of a BVH as Blender imports it
# (global scale 1: the file's units; Blender turns y-up into z-up: (x, y, z) -> (x, -z, y)).
# blender -b --python examples/import-checks/blender_positions_check.py -- FILE.bvh
import bpy, sys, builtins
_open = builtins.open
builtins.open = lambda f, mode="r", *a, **k: _open(f, mode.replace("U", ""), *a, **k)
path = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=path, global_scale=1.0, use_fps_scale=False, update_scene_fps=True, update_scene_duration=True)
arm = [o for o in bpy.context.scene.objects if o.type == 'ARMATURE'][0]
for f in (1, 60, 150):
    bpy.context.scene.frame_set(f)
    for b in ("Hips", "LeftHand", "RightFoot", "Head"):
        p = arm.matrix_world @ arm.pose.bones[b].head
        print(f"POS {f} {b} {p.x:.6f} {p.y:.6f} {p.z:.6f}")
