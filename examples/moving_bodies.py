# Rigid bodies moving on a ground plane, with ambient occlusion recomputed every frame.
#
# Each body's Coherent Shadow Map is built once; moving a body only changes
# its 4x4 transform in the pyshadow.Scene (Scene.set_transform), after which
# the per-vertex AO of every body and of a receiver grid on the ground is
# recomputed (Scene.vertex_ao) and drawn. Default bodies: the bundled Stanford
# bunny, a box, a ball and a capsule (or the MESH files given).
#
# Interactive: the sliders (or the arrow keys) move the first body along its
# orbit and turn it. With --frames N --screenshot out.png the scripted motion
# runs off screen for N frames, out.png holds the last frame (--save-frames
# also writes out_0000.png ...), and the AO frame rate is printed: the median
# time of set_transform + vertex_ao for all instances, after a warm-up frame.
#
#   python examples/moving_bodies.py                      # interactive window
#   python examples/moving_bodies.py --frames 60 --screenshot moving.png
from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass

import numpy as np

ORBIT = 1.9           # radius of the first body's path around the centre


@dataclass
class Body:
    """A mesh, its world bounding radius and where it rests: (x, z, yaw degrees)."""

    name: str
    mesh: object
    radius: float
    x: float
    z: float
    yaw: float = 0.0
    tilt: np.ndarray | None = None      # fixed rotation applied before the yaw (3, 3)


def default_bodies():
    import trimesh

    import pyshadow.data

    capsule = trimesh.creation.capsule(height=1.1, radius=0.3, count=[24, 24])   # along z
    lying = yaw_matrix(90.0)                                                     # along x
    return [
        Body("bunny", pyshadow.data.bunny(), 1.0, ORBIT, 0.0),
        Body("box", trimesh.creation.box((1.1, 0.7, 0.7)), 0.74, 0.0, 0.0, 20.0),
        Body("ball", trimesh.creation.icosphere(subdivisions=4, radius=0.45), 0.45, -3.0, 1.8),
        Body("capsule", capsule, 0.85, 1.2, -3.3, 0.0, lying),
    ]


def mesh_bodies(meshes, names):
    """Bodies from user meshes: the first orbits, the second sits in the centre, others on a ring."""
    bodies = []
    for k, (m, n) in enumerate(zip(meshes, names)):
        if k == 0:
            x, z = ORBIT, 0.0
        elif k == 1:
            x, z = 0.0, 0.0
        else:
            a = 2 * np.pi * (k - 2) / max(1, len(meshes) - 2) + 0.5
            x, z = 3.3 * np.cos(a), 3.3 * np.sin(a)
        bodies.append(Body(n, m, 0.75, x, z))
    return bodies


def yaw_matrix(deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def body_transform(body, x, z, yaw):
    from pyshadow import viz

    R = yaw_matrix(yaw) if body.tilt is None else yaw_matrix(yaw) @ body.tilt
    return viz.stand_on_ground(body.mesh, radius=body.radius, position=(x, z), rotation=R)


def orbit_pose(angle_deg, turn_deg):
    """(x, z, yaw) of the first body at ``angle_deg`` along its orbit, turned by ``turn_deg``."""
    a = np.radians(angle_deg)
    return ORBIT * np.cos(a), ORBIT * np.sin(a), -angle_deg + turn_deg


def scripted_transforms(bodies, frame, frames):
    """Transforms of every body at ``frame`` of ``frames``: one orbit of the first body,
    two turns of the second, the others at rest."""
    t = frame / max(frames, 1)
    out = []
    for k, b in enumerate(bodies):
        if k == 0:
            x, z, yaw = orbit_pose(360.0 * t, 0.0)
        elif k == 1:
            x, z, yaw = b.x, b.z, b.yaw + 720.0 * t
        else:
            x, z, yaw = b.x, b.z, b.yaw
        out.append(body_transform(b, x, z, yaw))
    return out


def recompute(scene, ids, transforms, sampling):
    """Move the bodies and recompute the AO of every instance (bodies and ground grid).

    Returns {instance id: (V,) float32 AO}."""
    scene.set_transform(np.asarray(ids), np.asarray(transforms))     # all bodies in one call
    return {i: scene.vertex_ao(i, sampling=sampling) for i in range(len(scene.instances))}


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Rigid bodies on a ground plane with AO recomputed as they move.")
    parser.add_argument("meshes", nargs="*", metavar="MESH",
                        help="mesh files for the bodies (default: bunny, box, ball, capsule)")
    parser.add_argument("--theta", type=int, default=24, help="zigzag rows of map directions")
    parser.add_argument("--phi", type=int, default=48, help="zigzag columns of map directions")
    parser.add_argument("--resolution", type=int, default=64, help="CSM texels per side")
    parser.add_argument("--samples", type=int, default=32, help="AO samples per vertex")
    parser.add_argument("--ground-divisions", type=int, default=80,
                        help="quads per side of the ground receiver grid")
    parser.add_argument("--frames", type=int, default=0,
                        help="frames of the scripted motion, off screen (needs --screenshot)")
    parser.add_argument("--save-frames", action="store_true",
                        help="also write every frame as OUT_0000.png, OUT_0001.png, ...")
    from pyshadow import viz

    viz.add_window_options(parser, window=(1100, 820))
    args = parser.parse_args(argv)
    if args.frames < 0:
        parser.error(f"--frames must be >= 0, got {args.frames}")
    if args.save_frames and not args.screenshot:
        parser.error("--save-frames needs --screenshot")

    import pyshadow

    try:
        sampling = pyshadow.Sampling(args.samples)
        if args.meshes:
            bodies = mesh_bodies([pyshadow.load_mesh(p) for p in args.meshes], args.meshes)
        else:
            bodies = default_bodies()
        t0 = time.perf_counter()
        scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(args.theta, args.phi),
                               resolution=args.resolution)
        start = scripted_transforms(bodies, 0, 1)
        ids = [scene.add(b.mesh, T) for b, T in zip(bodies, start)]
        t_build = time.perf_counter() - t0
        scene.add(viz.ground_grid((0.0, 0.0), 10.0, args.ground_divisions), casts=False)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(str(exc))
    verts = sum(len(inst.mesh.vertices) for inst in scene.instances)
    print(f"{len(bodies)} bodies ({', '.join(b.name for b in bodies)}) + ground grid, "
          f"{verts} vertices; CSMs ({args.theta}x{args.phi} maps of {args.resolution}^2) "
          f"built in {t_build:.2f} s")
    ao = recompute(scene, ids, start, sampling)       # warm-up: kernel builds, device data

    plotter = viz.script_plotter(parser, args, (2, 1), row_weights=[1.0, 0.1])
    plotter.subplot(0, 0)
    drawn = viz.scene_to_plotter(scene, plotter, ao, ground=False, lighting=False)
    viz.look_at_bodies(plotter, (0.0, 0.3, 0.0), 3.9, direction=(0.45, 0.8, 1.0), fill=1.05)
    title = viz.add_title(plotter, "moving bodies: AO recomputed every frame")
    plotter.subplot(1, 0)
    viz.colour_bar(plotter, "ambient occlusion (1 = open)", cmap="gray", clim=(0.0, 1.0))
    plotter.subplot(0, 0)

    def show(values, transforms, text):
        for i, T in zip(ids, transforms):
            drawn[i][1].user_matrix = T
        for i, v in values.items():
            viz.update_scalars(drawn[i][0], v)
        viz.update_title(plotter, title, text)

    if args.screenshot is None:
        if args.frames:         # the window runs no scripted motion: it was ignored (after the display check)
            plotter.close()
            parser.error("--frames needs --screenshot (the interactive window is moved by its sliders)")
        state = {"angle": 0.0, "turn": 0.0}
        sliders = {}

        def move(angle=None, turn=None):
            if angle is not None:
                state["angle"] = float(angle) % 360.0
            if turn is not None:
                state["turn"] = float(np.clip(turn, -180.0, 180.0))
            for key, widget in sliders.items():          # keys move the sliders too
                widget.GetRepresentation().SetValue(state[key])
            transforms = [body_transform(bodies[0], *orbit_pose(state["angle"], state["turn"]))]
            t = time.perf_counter()
            values = recompute(scene, ids[:1], transforms, sampling)
            ms = 1e3 * (time.perf_counter() - t)
            show(values, transforms, f"{bodies[0].name} at {state['angle']:.0f} deg, turned "
                                     f"{state['turn']:.0f} deg: AO in {ms:.0f} ms")
            plotter.render()

        sliders["angle"] = plotter.add_slider_widget(
            lambda v: move(angle=v), [0.0, 360.0], value=0.0,
            title="position on the orbit (Left/Right)", pointa=(0.05, 0.12), pointb=(0.45, 0.12),
            color=viz.TEXT_COLOR, interaction_event="always")
        sliders["turn"] = plotter.add_slider_widget(
            lambda v: move(turn=v), [-180.0, 180.0], value=0.0, title="turn (Up/Down)",
            pointa=(0.55, 0.12), pointb=(0.95, 0.12), color=viz.TEXT_COLOR,
            interaction_event="always")
        plotter.add_key_event("Left", lambda: move(angle=state["angle"] - 5.0))
        plotter.add_key_event("Right", lambda: move(angle=state["angle"] + 5.0))
        plotter.add_key_event("Up", lambda: move(turn=state["turn"] + 10.0))
        plotter.add_key_event("Down", lambda: move(turn=state["turn"] - 10.0))
        viz.finish(plotter, None, title="pyshadow: moving bodies")
        return 0

    frames = max(1, args.frames)
    stem = os.path.splitext(args.screenshot)[0]          # OUT of OUT.jpg too (was out.jpg_0000.png)
    plan = [scripted_transforms(bodies, f, frames) for f in range(frames)]   # not timed
    times = []
    for f, transforms in enumerate(plan):
        t = time.perf_counter()
        values = recompute(scene, ids, transforms, sampling)
        times.append(time.perf_counter() - t)
        show(values, transforms, f"frame {f + 1}/{frames}: AO of {verts} vertices, "
                                 f"{args.samples} samples, in {1e3 * times[-1]:.0f} ms")
        if args.save_frames:
            viz.save_screenshot(plotter, f"{stem}_{f:04d}.png")
    med = float(np.median(times))
    print(f"AO frames per second: {1.0 / med:.2f} (median frame time {1e3 * med:.1f} ms over "
          f"{frames} frames: set_transform + vertex_ao of {len(scene.instances)} instances, "
          f"{verts} vertices, {args.samples} samples; device {pyshadow.device_info()['name']})")
    out = viz.finish(plotter, args.screenshot)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
