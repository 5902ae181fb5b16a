import bpy, sys
import builtins
_open = builtins.open
def _compat_open(f, mode="r", *a, **k):
    return _open(f, mode.replace("U", ""), *a, **k)
builtins.open = _compat_open  # Debian Blender 3.4 importer uses mode "rU", removed in Python 3.11
path = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=path, global_scale=0.001, use_fps_scale=False, update_scene_fps=True, update_scene_duration=True)
arm = [o for o in bpy.context.scene.objects if o.type == 'ARMATURE'][0]
scene = bpy.context.scene
scene.frame_set(scene.frame_start)
root0 = (arm.matrix_world @ arm.pose.bones['Hips'].head).copy()
scene.frame_set(int(arm.animation_data.action.frame_range[1]))
root1 = (arm.matrix_world @ arm.pose.bones['Hips'].head).copy()
rng = arm.animation_data.action.frame_range
print(f"BLENDER: {len(arm.pose.bones)} bones, action frames {rng[0]:.0f}..{rng[1]:.0f}, fps {scene.render.fps}, root moved {(root1 - root0).length:.2f} m")
