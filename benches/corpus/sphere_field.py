#!/usr/bin/env python3
"""Writes sphere-field.toml: the closing scene of the one-weekend ray tracing book, as
users first try it here. A 22x22 lattice of small spheres (diffuse, metal or glass,
chosen by a fixed hash so the file is the same every time), three large ones, a ground
sphere of radius 1000, lit by the background alone, seen through a thin lens.

    python3 benches/corpus/sphere_field.py > benches/corpus/sphere-field.toml
"""


def unit(n):
    """A number in [0, 1) from the integer n (a 32-bit integer hash, lowbias32)."""
    x = n & 0xFFFFFFFF
    x ^= x >> 16
    x = (x * 0x7FEB352D) & 0xFFFFFFFF
    x ^= x >> 15
    x = (x * 0x846CA68B) & 0xFFFFFFFF
    x ^= x >> 16
    return x / 2**32


DIFFUSE = 40  # diffuse albedos in the palette
METAL = 12  # metal albedos and fuzzes


def main():
    out = []
    w = out.append
    w('description = "A field of 480 small diffuse, metal and glass spheres, path-traced, '
      'lit by the sky, thin lens (the one-weekend book\'s closing scene)"')
    w("background = [0.7, 0.8, 1.0]")
    w("")
    w("[camera]")
    w("width = 400")
    w('aspect_ratio = "16:9"')
    w("samples_per_pixel = 16")
    w("max_depth = 20")
    w("vfov = 20")
    w("look_from = [13, 2, 3]")
    w("look_at = [0, 0, 0]")
    w("up = [0, 1, 0]")
    w("defocus_angle = 0.6")
    w("focus_dist = 10")
    w("")
    w("[materials.ground]")
    w('type = "diffuse"')
    w("albedo = [0.5, 0.5, 0.5]")
    w("")
    w("[materials.glass]")
    w('type = "dielectric"')
    w("index = 1.5")
    w("")
    for i in range(DIFFUSE):
        r, g, b = (unit(3 * i + k) * unit(1000 + 3 * i + k) for k in range(3))
        w(f"[materials.diffuse{i}]")
        w('type = "diffuse"')
        w(f"albedo = [{r:.3f}, {g:.3f}, {b:.3f}]")
        w("")
    for i in range(METAL):
        r, g, b = (0.5 + 0.5 * unit(2000 + 3 * i + k) for k in range(3))
        w(f"[materials.metal{i}]")
        w('type = "metal"')
        w(f"albedo = [{r:.3f}, {g:.3f}, {b:.3f}]")
        w(f"fuzz = {0.5 * unit(3000 + i):.3f}")
        w("")
    w("[materials.brown]")
    w('type = "diffuse"')
    w("albedo = [0.4, 0.2, 0.1]")
    w("")
    w("[materials.mirror]")
    w('type = "metal"')
    w("albedo = [0.7, 0.6, 0.5]")
    w("fuzz = 0")
    w("")

    def sphere(center, radius, material):
        w("[[objects]]")
        w('type = "sphere"')
        w("center = [{:.4f}, {:.4f}, {:.4f}]".format(*center))
        w(f"radius = {radius}")
        w(f'material = "{material}"')
        w("")

    sphere((0, -1000, 0), 1000, "ground")
    n = 0
    for a in range(-11, 11):
        for b in range(-11, 11):
            key = 4000 + 4 * ((a + 11) * 22 + (b + 11))
            center = (a + 0.9 * unit(key), 0.2, b + 0.9 * unit(key + 1))
            if (center[0] - 4) ** 2 + (center[2]) ** 2 <= 0.81:
                continue
            choose = unit(key + 2)
            pick = unit(key + 3)
            if choose < 0.8:
                material = f"diffuse{int(pick * DIFFUSE)}"
            elif choose < 0.95:
                material = f"metal{int(pick * METAL)}"
            else:
                material = "glass"
            sphere(center, 0.2, material)
            n += 1
    sphere((0, 1, 0), 1.0, "glass")
    sphere((-4, 1, 0), 1.0, "brown")
    sphere((4, 1, 0), 1.0, "mirror")
    assert n == 480, n
    print("\n".join(out).rstrip())


if __name__ == "__main__":
    main()
