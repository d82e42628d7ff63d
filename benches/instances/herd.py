#!/usr/bin/env python3
"""Write the instancing benchmark's two scenes into DIR: 64 bunnies, each turned and
placed on a Phong floor under a point light, as 64 mesh objects (`herd-flat.toml`, the
triangles flattened into the scene) and as one `[meshes.bunny]` with 64 instances
(`herd-instanced.toml`). Both name `bunny.obj` beside them (a copy of assets/bunny.obj).

    benches/instances/herd.py DIR
"""
import shutil
import sys
from pathlib import Path

HEAD = '''description = "64 bunnies, {how}"
ambient = [0.1, 0.1, 0.1]

[camera]
width = 1280
aspect_ratio = "16:9"
samples_per_pixel = 1
look_from = [0, 2.2, 3.2]
look_at = [0, 0, 0]
vfov = 50

[materials.floor]
type = "phong"
albedo = [0.6, 0.6, 0.6]
shininess = 10

[materials.clay]
type = "phong"
albedo = [0.8, 0.5, 0.4]
shininess = 60

[materials.lamp]
type = "light"
color = [1, 1, 1]

[[objects]]
type = "quad"
corner = [-5, 0, 5]
u = [10, 0, 0]
v = [0, 0, -10]
material = "floor"

[[objects]]
type = "sphere"
center = [2, 5, 3]
radius = 0.2
material = "lamp"
'''


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy(Path(__file__).resolve().parents[2] / "assets" / "bunny.obj", out)
    flat = HEAD.format(how="as mesh objects")
    placed = HEAD.format(how="as instances of one mesh")
    for i in range(8):
        for j in range(8):
            x, z, degrees = -2.1 + i * 0.6, -3.5 + j * 0.6, (i * 37 + j * 91) % 360
            keys = (f"scale = 4\nrotate = [{{ axis = [0, 1, 0], degrees = {degrees} }}]\n"
                    f"translate = [{x:.3f}, -0.13, {z:.3f}]\n")
            flat += f'\n[[objects]]\ntype = "mesh"\npath = "bunny.obj"\nmaterial = "clay"\n{keys}'
            placed += f'\n[[objects]]\ntype = "instance"\nmesh = "bunny"\n{keys}'
    placed += '\n[meshes.bunny]\npath = "bunny.obj"\nmaterial = "clay"\n'
    (out / "herd-flat.toml").write_text(flat)
    (out / "herd-instanced.toml").write_text(placed)


if __name__ == "__main__":
    main()
