"""Imports a BVH written by `mocapctl bvh` into Blender, headless, with the importer's default
axes (forward -Z, up Y), and prints where the body ends up in Blender's Z-up world: upright, its
feet on the floor, its head at the body's height, travelling as fast as the file's root does.
Exits 1 if any check fails. A manual check (not run by ctest: it needs Blender):

    blender -b --python-exit-code 1 --python clients/mocapctl/blender_bvh_check.py -- FILE.bvh [--cm]

--cm: the file is in centimetres (mocapctl bvh --units cm); it is imported at scale 0.01.
"""

import builtins
import math
import statistics
import sys

import bpy
import io_anim_bvh.import_bvh as import_bvh


# Blender 3.4's importer opens the file with mode 'rU', which Python 3.11 refuses: give its module
# an open() that drops the 'U' (universal newlines are the default anyway).
def _open_without_u(file, mode="r", *args, **kwargs):
    return builtins.open(file, mode.replace("U", ""), *args, **kwargs)


import_bvh.open = _open_without_u


def arguments():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    paths = [a for a in argv if not a.startswith("--")]
    if len(paths) != 1:
        raise SystemExit("usage: blender -b --python blender_bvh_check.py -- FILE.bvh [--cm]")
    return paths[0], 0.01 if "--cm" in argv else 1.0


def path_speed(points, frame_time):
    """Mean speed (m/s) along a path of (x, y) floor positions a frame apart."""
    length = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:]))
    return length / (frame_time * (len(points) - 1)) if len(points) > 1 else 0.0


def file_root_path(path, metres_per_unit):
    """The root's floor positions (metres) from the file's own position channels (Y up: the floor
    is x and -z, as Blender turns them), and the file's frame time."""
    with builtins.open(path) as f:
        lines = f.read().splitlines()
    motion = lines.index("MOTION")
    frame_time = float(lines[motion + 2].split(":")[1])
    frames = [list(map(float, line.split())) for line in lines[motion + 3:] if line.strip()]
    return [(v[0] * metres_per_unit, -v[2] * metres_per_unit) for v in frames], frame_time


def main():
    path, scale = arguments()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=path, global_scale=scale, update_scene_fps=True)
    armature = bpy.context.object
    scene = bpy.context.scene
    bones = armature.data.bones
    root = next(b.name for b in bones if b.parent is None)
    head = "head" if "head" in bones else max(bones, key=lambda b: b.tail_local.z).name
    rest_lowest = min(min(b.head_local.z, b.tail_local.z) for b in bones)
    rest_height = bones[head].tail_local.z - rest_lowest

    file_path, frame_time = file_root_path(path, scale)
    tilts, lowest, head_tops, roots = [], [], [], []
    # One Blender frame per BVH frame (the scene's rate set to the file's), from frame 1.
    for frame in range(1, len(file_path) + 1):
        scene.frame_set(frame)
        world = armature.matrix_world
        points = [world @ p for pb in armature.pose.bones for p in (pb.head, pb.tail)]
        pelvis = world @ armature.pose.bones[root].head
        head_top = world @ armature.pose.bones[head].tail
        up = head_top - pelvis
        tilts.append(math.degrees(math.acos(max(-1.0, min(1.0, up.z / up.length)))))
        lowest.append(min(p.z for p in points))
        head_tops.append(head_top.z)
        roots.append(pelvis)

    blender_speed = path_speed([(r.x, r.y) for r in roots], frame_time)
    file_speed = path_speed(file_path, frame_time)
    checks = [
        ("frames", "%d, %.1f s" % (len(roots), frame_time * (len(roots) - 1)), len(roots) > 1),
        ("upright: pelvis-to-head-top tilt from +Z, median / max (deg)",
         "%.1f / %.1f" % (statistics.median(tilts), max(tilts)), statistics.median(tilts) < 30),
        ("feet: lowest point above the floor, median / min (m)",
         "%.3f / %.3f" % (statistics.median(lowest), min(lowest)),
         abs(statistics.median(lowest)) < 0.08),
        ("head top above the floor, median (m); the body's rest height",
         "%.3f; %.3f" % (statistics.median(head_tops), rest_height),
         abs(statistics.median(head_tops) - rest_height) < 0.15 * rest_height),
        ("root: mean speed over the floor in Blender / in the file (m/s)",
         "%.3f / %.3f" % (blender_speed, file_speed),
         abs(blender_speed - file_speed) <= 0.01 * max(file_speed, 0.1)),
    ]
    print("blender_bvh_check: %s (Blender %s, scale %g, %d fps, up Z)"
          % (path, bpy.app.version_string, scale, scene.render.fps))
    for name, value, ok in checks:
        print("  %-68s %-16s %s" % (name, value, "ok" if ok else "FAILED"))
    print("  root from (%.2f, %.2f, %.2f) to (%.2f, %.2f, %.2f) m"
          % (roots[0].x, roots[0].y, roots[0].z, roots[-1].x, roots[-1].y, roots[-1].z))
    if not all(ok for _, _, ok in checks):
        sys.exit(1)


main()
