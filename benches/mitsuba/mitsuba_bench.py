#!/usr/bin/env python3
"""Our renderer against Mitsuba 3 on the same scenes, alternating in one run.

Reads the project's own scene files (scenes/*.toml), builds each with Mitsuba's Python
dict API (the same camera, image size and samples per pixel; the closest Mitsuba
integrator, BSDFs and emitters: README.md beside this file lists where they differ), and
times Mitsuba's renders against `raytracer` on the same thread count.

    mitsuba_bench.py run --raytracer target/release/raytracer [--scenes cornell,bunny]
                         [--threads 1,2] [--rounds 5] [--warm 3] [--scalar-rounds 1]
    mitsuba_bench.py render SCENE --variant llvm_ad_rgb --threads 1 [--warm 3]
                         [--hold-avx2] [--png FILE]     (one Mitsuba process; JSON out)
    mitsuba_bench.py summary LOG                         (the table of a run's --log)
    mitsuba_bench.py dict SCENE                          (print the Mitsuba scene)

`run` starts one process per render run, ours then Mitsuba's, scene by scene and thread
count by thread count, round after round, so a change of the machine's load falls on
both. Each Mitsuba process gets an empty DRJIT_CACHE_DIR, so its first render includes
the JIT compilation; it then renders the same scene again (`--warm` times) in the same
process, from the kernels in memory. benches/mitsuba/run.sh sets up the environment.
"""

import argparse
import json
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
SCENES = ["cornell", "bunny", "mixed", "quads", "spheres"]
PATH_TRACED = {"diffuse", "metal", "dielectric"}
AREA_LIGHT_SAMPLES = 10  # the project's rule: quad, triangle, box and mesh lights


class SceneError(Exception):
    pass


# ---------------------------------------------------------------------------------------
# The project's scene files, with the project's defaults (scenes/README.md).


def load_scene(name):
    """The scene file `scenes/NAME.toml` (or a path), parsed, with its directory."""
    path = name if name.endswith(".toml") else os.path.join(ROOT, "scenes", name + ".toml")
    try:
        with open(path, "rb") as f:
            return tomllib.load(f), os.path.dirname(os.path.abspath(path))
    except OSError as e:
        raise SceneError(f"{path}: {e.strerror}") from e
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{path}: {e}") from e


def camera_of(desc):
    cam = desc.get("camera", {})
    width = cam.get("width", 100)
    aspect = cam.get("aspect_ratio", 1.0)
    if isinstance(aspect, str):
        w, h = (int(s) for s in aspect.split(":"))
        height = width * h // w
    else:
        height = int(width / aspect)
    return {
        "width": width,
        "height": max(height, 1),
        "spp": cam.get("samples_per_pixel", 10),
        "max_depth": cam.get("max_depth", 10),
        "vfov": cam.get("vfov", 90.0),
        "look_from": cam.get("look_from", [0.0, 0.0, 0.0]),
        "look_at": cam.get("look_at", [0.0, 0.0, -1.0]),
        "up": cam.get("up", [0.0, 1.0, 0.0]),
    }


def sub(a, b):
    return [x - y for x, y in zip(a, b)]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


def scale(a, s):
    return [x * s for x in a]


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    return scale(a, 1.0 / math.sqrt(dot(a, a)))


def object_centre(obj):
    kind = obj["type"]
    if kind == "sphere":
        return obj["center"]
    if kind == "quad":
        return add(obj["corner"], scale(add(obj["u"], obj["v"]), 0.5))
    if kind == "box":
        return scale(add(*obj["corners"]), 0.5)
    raise SceneError(f"no centre for a {kind} light")


# ---------------------------------------------------------------------------------------
# The Mitsuba scene.


def rgb(value):
    return {"type": "rgb", "value": [float(c) for c in value]}


def schlick_r0(index):
    return ((1.0 - index) / (1.0 + index)) ** 2


def bsdf_of(material):
    """The closest Mitsuba BSDF; two-sided like the project's surfaces."""
    kind = material["type"]
    if kind in ("phong", "diffuse"):
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(material["albedo"])}}
    if kind == "phong_mirror":
        blend = {
            "type": "blendbsdf",
            "weight": schlick_r0(material["index"]),
            "diffuse": {"type": "diffuse", "reflectance": rgb(material["albedo"])},
            "mirror": {"type": "conductor", "material": "none"},
        }
        return {"type": "twosided", "bsdf": blend}
    if kind == "metal":
        fuzz = min(material.get("fuzz", 0.0), 1.0)
        if fuzz > 0:
            metal = {"type": "roughconductor", "material": "none", "alpha": fuzz}
        else:
            metal = {"type": "conductor", "material": "none"}
        metal["specular_reflectance"] = rgb(material["albedo"])
        return {"type": "twosided", "bsdf": metal}
    if kind == "dielectric":
        return {"type": "dielectric", "int_ior": float(material["index"]), "ext_ior": 1.0}
    raise SceneError(f"material type {kind!r} has no Mitsuba counterpart here")


def shape_of(mi, obj, scene_dir):
    """The Mitsuba shape of an object."""
    kind = obj["type"]
    if kind == "sphere":
        return {"type": "sphere", "center": obj["center"], "radius": float(obj["radius"])}
    if kind == "quad":
        # Mitsuba's rectangle is [-1, 1]^2 at z = 0, facing +z.
        corner, u, v = obj["corner"], obj["u"], obj["v"]
        n = normalize(cross(u, v))
        centre = add(corner, scale(add(u, v), 0.5))
        columns = [scale(u, 0.5), scale(v, 0.5), n, centre]
        matrix = [[columns[c][r] for c in range(4)] for r in range(3)] + [[0, 0, 0, 1]]
        return {"type": "rectangle", "to_world": mi.ScalarTransform4f(matrix)}
    if kind == "box":
        a, b = obj["corners"]
        centre = scale(add(a, b), 0.5)
        half = [abs(x) * 0.5 for x in sub(b, a)]
        return {"type": "cube", "to_world": mi.ScalarTransform4f().translate(centre).scale(half)}
    if kind == "mesh":
        path = os.path.normpath(os.path.join(scene_dir, obj["path"]))
        return {"type": "obj", "filename": path, "face_normals": True}
    raise SceneError(f"object type {kind!r} has no Mitsuba counterpart here")


def light_quad_facing(obj, look_at):
    """A quad light with its edges swapped if u x v points away from the camera's target
    (Mitsuba's area emitters light one side only)."""
    n = cross(obj["u"], obj["v"])
    if dot(n, sub(look_at, obj["corner"])) < 0:
        return dict(obj, u=obj["v"], v=obj["u"])
    return obj


def mitsuba_scene(mi, name):
    """The Mitsuba dict of a project scene, and what it was made of."""
    desc, scene_dir = load_scene(name)
    cam = camera_of(desc)
    materials = desc.get("materials", {})
    objects = desc.get("objects", [])
    path_traced = any(m["type"] in PATH_TRACED for m in materials.values())

    scene = {
        "type": "scene",
        "sensor": {
            "type": "perspective",
            "fov": float(cam["vfov"]),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam["look_from"], target=cam["look_at"], up=cam["up"]
            ),
            "film": {
                "type": "hdrfilm",
                "width": cam["width"],
                "height": cam["height"],
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": {"type": "independent", "sample_count": cam["spp"]},
        },
    }
    area_lights = 0
    point_lights = 0
    for i, obj in enumerate(objects):
        mat_name = obj.get("material")
        if mat_name not in materials:
            raise SceneError(f"object {i}: unknown material {mat_name!r}")
        material = materials[mat_name]
        if material["type"] == "light":
            # The project's light radiance has no fall-off; Mitsuba's does. Scaled so a
            # diffuse surface at the camera's target, facing the light, is lit as ours
            # (kd = 0.5): the same work either way, a comparable picture.
            e = scale(material["color"], material.get("intensity", 1.0))
            d2 = dot(sub(cam["look_at"], object_centre(obj)), sub(cam["look_at"], object_centre(obj)))
            if obj["type"] == "sphere":
                # A sphere light is a point light at its centre, with no surface.
                scene[f"light_{i}"] = {
                    "type": "point",
                    "position": obj["center"],
                    "intensity": rgb(scale(e, 0.5 * math.pi * d2)),
                }
                point_lights += 1
                continue
            if obj["type"] == "quad":
                obj = light_quad_facing(obj, cam["look_at"])
                area = math.sqrt(dot(cross(obj["u"], obj["v"]), cross(obj["u"], obj["v"])))
            else:
                raise SceneError(f"object {i}: a {obj['type']} light is not supported here")
            shape = shape_of(mi, obj, scene_dir)
            shape["emitter"] = {"type": "area", "radiance": rgb(scale(e, 0.5 * math.pi * d2 / area))}
            shape["bsdf"] = {"type": "diffuse", "reflectance": rgb([0, 0, 0])}
            area_lights += 1
        else:
            shape = shape_of(mi, obj, scene_dir)
            shape["bsdf"] = bsdf_of(material)
        scene[f"object_{i}"] = shape

    if path_traced:
        # No Russian roulette: the project's paths end only at max_depth or a Phong hit.
        integrator = {"type": "path", "max_depth": cam["max_depth"], "rr_depth": cam["max_depth"] + 1}
    else:
        # One shadow ray per point light, ten per area light; no BSDF-sampled rays (the
        # project traces none from a Phong surface).
        samples = AREA_LIGHT_SAMPLES if area_lights else 1
        integrator = {"type": "direct", "emitter_samples": samples, "bsdf_samples": 0}
    if area_lights + point_lights > 1:
        raise SceneError("more than one light: emitter sampling would differ from the project's")
    scene["integrator"] = integrator
    return scene, cam


# ---------------------------------------------------------------------------------------
# One Mitsuba process: load, first render, warm renders.


def drjit_core(dr):
    import ctypes

    lib = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    # Dr.Jit exports its LLVM target functions with C++ names only.
    get_cpu = lib._Z19jit_llvm_target_cpuv
    get_cpu.restype = ctypes.c_char_p
    get_features = lib._Z24jit_llvm_target_featuresv
    get_features.restype = ctypes.c_char_p
    get_width = lib._Z21jit_llvm_vector_widthv
    get_width.restype = ctypes.c_uint32
    set_target = lib._Z19jit_llvm_set_targetPKcS0_j
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    return get_cpu, get_features, get_width, set_target


def llvm_target(dr, hold_avx2):
    """Dr.Jit's LLVM target (cpu, AVX-512 on, vector width); with `hold_avx2`, the
    host's CPU with every AVX-512 feature turned off and 8 lanes first."""
    get_cpu, get_features, get_width, set_target = drjit_core(dr)
    dr.eval(dr.llvm.Float(0.0) + 1.0)  # initialises the LLVM backend
    if hold_avx2:
        features = get_features().decode()
        held = ",".join("-" + f[1:] if f.startswith("+avx512") else f for f in features.split(","))
        set_target(get_cpu(), held.encode(), 8)
    features = get_features().decode().split(",")
    return {
        "cpu": get_cpu().decode(),
        "avx512": sorted(f[1:] for f in features if f.startswith("+avx512")),
        "vector_width": get_width(),
    }


def timed_render(mi, dr, scene, spp, seed):
    wall0, cpu0 = time.perf_counter(), time.process_time()
    image = mi.render(scene, seed=seed, spp=spp)
    dr.eval(image)
    dr.sync_thread()
    wall = time.perf_counter() - wall0
    return image, wall, time.process_time() - cpu0


def render_main(args):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    dr.set_thread_count(args.threads)
    out = {
        "scene": args.scene,
        "variant": args.variant,
        "threads": args.threads,
        "mitsuba": mi.__version__,
        "drjit": dr.__version__,
        "cache_dir": os.environ.get("DRJIT_CACHE_DIR"),
    }
    if args.variant.startswith("llvm"):
        out["llvm"] = ".".join(str(v) for v in dr.detail.llvm_version())
        out["target"] = llvm_target(dr, args.hold_avx2)
    desc, cam = mitsuba_scene(mi, args.scene)
    t0 = time.perf_counter()
    scene = mi.load_dict(desc)
    out["load"] = time.perf_counter() - t0
    jit = args.variant.startswith("llvm")
    if jit:
        # Dr.Jit's own account of the first render's kernels: tracing to LLVM IR and
        # LLVM's compilation (milliseconds), cache misses since the cache dir is empty.
        dr.set_flag(dr.JitFlag.KernelHistory, True)
    image, out["first"], out["first_cpu"] = timed_render(mi, dr, scene, cam["spp"], 0)
    if jit:
        kernels = [k for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]
        dr.set_flag(dr.JitFlag.KernelHistory, False)
        out["compile"] = sum(k["codegen_time"] + k["backend_time"] for k in kernels) / 1000
        out["compiled_kernels"] = sum(1 for k in kernels if not k["cache_hit"])
    out["warm"], out["warm_cpu"] = [], []
    for _ in range(args.warm):
        _, wall, cpu = timed_render(mi, dr, scene, cam["spp"], 0)
        out["warm"].append(wall)
        out["warm_cpu"].append(cpu)
    out["size"] = [cam["width"], cam["height"], cam["spp"]]
    if args.png:
        mi.util.write_bitmap(args.png, image)
    print(json.dumps(out))


# ---------------------------------------------------------------------------------------
# The alternating run.


def loadavg():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def run_ours(raytracer, scene, threads, work, packet_width):
    report = os.path.join(work, "ours.json")
    image = os.path.join(work, "ours.png")
    width = ["--packet-width", str(packet_width)] if packet_width else []
    cmd = [raytracer, scene, "--threads", str(threads), *width,
           "--sampler", "independent", "-q", "--report", report, "-o", image]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    process = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    with open(report) as f:
        r = json.load(f)
    os.remove(report)
    os.remove(image)
    return {"process": process, "process_cpu": cpu, "render": r["seconds"]["render"], "rays": r["rays"]}


def run_mitsuba(scene, threads, variant, warm, hold_avx2, work, png=None):
    cache = tempfile.mkdtemp(prefix="drjit-cache-", dir=work)
    env = dict(os.environ, DRJIT_CACHE_DIR=cache)
    cmd = [sys.executable, os.path.abspath(__file__), "render", scene, "--variant", variant,
           "--threads", str(threads), "--warm", str(warm)]
    if hold_avx2:
        cmd.append("--hold-avx2")
    if png:
        cmd += ["--png", png]
    try:
        t0 = time.perf_counter()
        done = subprocess.run(cmd, check=True, env=env, stdout=subprocess.PIPE, text=True)
        process = time.perf_counter() - t0
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["process"] = process
    return out


def paired(ours, theirs, ratio):
    """The median over rounds of the ratio of one round's two runs (run one after the
    other, so they share that moment's load)."""
    by_round = {r["round"]: r for r in theirs}
    return median([ratio(o, by_round[o["round"]]) for o in ours if o["round"] in by_round])


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def fmt_range(xs, digits=3):
    if not xs:
        return "-"
    return f"{median(xs):.{digits}f} ({min(xs):.{digits}f}-{max(xs):.{digits}f})"


def run_main(args):
    raytracer = os.path.abspath(args.raytracer)
    if not os.access(raytracer, os.X_OK):
        print(f"--raytracer {args.raytracer}: not an executable (cargo build --release)", file=sys.stderr)
        return 2
    scenes = args.scenes.split(",")
    threads = [int(t) for t in args.threads.split(",")]
    # Images, reports and Dr.Jit caches of the runs; removed at the end, whatever happens.
    work = tempfile.mkdtemp(prefix="raytracer-vs-mitsuba-")
    try:
        runs = measure(args, raytracer, scenes, threads, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if args.log:
        print(f"\nevery run: {args.log}")
    summarize(runs)
    return 0


def measure(args, raytracer, scenes, threads, work):
    """Every run of every round, in order, each printed as it ends."""
    # Whether holding Dr.Jit to AVX2 and 8 lanes changes anything on this CPU.
    probe = run_mitsuba(scenes[0], 1, "llvm_ad_rgb", 0, False, work)
    target = probe["target"]
    hold = args.hold_avx2 == "yes" or (
        args.hold_avx2 == "auto" and (target["avx512"] or target["vector_width"] != 8)
    )
    version = subprocess.run([raytracer, "--version"], capture_output=True, text=True).stdout
    width = args.packet_width or "the default"
    print(f"ours: {version.strip()}; packet width {width}", flush=True)
    print(f"mitsuba {probe['mitsuba']}, drjit {probe['drjit']}, LLVM {probe['llvm']}; "
          f"Dr.Jit's LLVM target: {target['cpu']}, {target['vector_width']} lanes, "
          f"AVX-512 {'on' if target['avx512'] else 'off'}"
          + ("" if hold else " (so no runs held to AVX2 and 8 lanes: they would be the same)"),
          flush=True)

    log = open(args.log, "a") if args.log else None
    runs = []
    try:
        for rnd in range(1, args.rounds + 1):
            for scene in scenes:
                for t in threads:
                    kinds = [("ours", None), ("llvm", False)]
                    if hold:
                        kinds.append(("llvm-avx2", True))
                    if rnd <= args.scalar_rounds:
                        kinds.append(("scalar", None))
                    for kind, held in kinds:
                        load = loadavg()
                        if kind == "ours":
                            r = run_ours(raytracer, scene, t, work, args.packet_width)
                        elif kind == "scalar":
                            r = run_mitsuba(scene, t, "scalar_rgb", 0, False, work)
                        else:
                            png = None
                            if args.pictures and rnd == 1 and t == threads[0] and not held:
                                os.makedirs(args.pictures, exist_ok=True)
                                png = os.path.join(os.path.abspath(args.pictures), f"{scene}-mitsuba.png")
                            r = run_mitsuba(scene, t, "llvm_ad_rgb", args.warm, held, work, png)
                        r.update(round=rnd, scene=scene, threads=t, kind=kind, loadavg=load)
                        runs.append(r)
                        if log:
                            log.write(json.dumps(r) + "\n")
                            log.flush()
                        if kind == "ours":
                            line = f"process {r['process']:.3f} s, render {r['render']:.3f} s"
                        elif kind == "scalar":
                            line = f"render {r['first']:.3f} s"
                        else:
                            line = (f"process {r['process']:.3f} s, load {r['load']:.3f} s, first "
                                    f"{r['first']:.3f} s (compilation {r['compile']:.3f} s), "
                                    f"warm {median(r['warm']):.3f} s")
                        print(f"round {rnd} {scene:8} T={t} {kind:9} {line} (load {load:.2f})", flush=True)
    finally:
        if log:
            log.close()
    return runs


def summary_main(args):
    with open(args.log) as f:
        runs = [json.loads(line) for line in f if line.strip()]
    if not runs:
        print(f"{args.log}: no runs", file=sys.stderr)
        return 2
    summarize(runs)
    return 0


def summarize(runs):
    scenes = list(dict.fromkeys(r["scene"] for r in runs))
    threads = sorted({r["threads"] for r in runs})
    hold = any(r["kind"] == "llvm-avx2" for r in runs)

    def pick(scene, t, kind):
        return [r for r in runs if r["scene"] == scene and r["threads"] == t and r["kind"] == kind]

    loads = [r["loadavg"] for r in runs]
    rounds = max(r["round"] for r in runs)
    print(f"\nmedians over {rounds} rounds, seconds (range); load average {min(loads):.2f}-{max(loads):.2f}")
    print("ours: raytracer SCENE --threads T [--packet-width W] --sampler independent -q --report")
    print("Mitsuba llvm_ad_rgb: first render (empty DRJIT_CACHE_DIR, JIT compilation included, and")
    print("what Dr.Jit's kernel history counts of it: tracing to LLVM IR and LLVM's compilation) and")
    print("warm renders (the median of each process's warm renders); ours vs X = t_X / t_ours,")
    print("ours' render phase against Mitsuba's warm render, ours' process against Mitsuba's first")
    print("render (Mitsuba's process also imports Python modules: its own column); paired: the")
    print("median over rounds of each round's ratio; CPU: the processes' CPU time, all threads\n")
    head = ["scene", "T", "ours process", "ours render", "Mitsuba process", "Mitsuba first",
            "of which compilation", "Mitsuba warm", "ours vs warm", "paired", "ours process vs first"]
    if hold:
        head += ["warm, AVX2 8 lanes", "ours vs that"]
    head += ["scalar_rgb", "ours vs scalar_rgb", "CPU s: ours process, Mitsuba warm", "ours vs warm, CPU"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for scene in scenes:
        for t in threads:
            ours = pick(scene, t, "ours")
            llvm = pick(scene, t, "llvm")
            o_proc = [r["process"] for r in ours]
            o_rend = [r["render"] for r in ours]
            o_cpu = [r["process_cpu"] for r in ours]
            m_proc = [r["process"] for r in llvm]
            m_first = [r["first"] for r in llvm]
            m_warm = [median(r["warm"]) for r in llvm]
            m_cpu = [median(r["warm_cpu"]) for r in llvm]
            m_compile = [r["compile"] for r in llvm if "compile" in r]
            row = [scene, str(t), fmt_range(o_proc), fmt_range(o_rend), fmt_range(m_proc),
                   fmt_range(m_first), fmt_range(m_compile), fmt_range(m_warm),
                   f"{median(m_warm) / median(o_rend):.2f}x",
                   f"{paired(ours, llvm, lambda o, m: median(m['warm']) / o['render']):.2f}x",
                   f"{median(m_first) / median(o_proc):.2f}x"]
            if hold:
                h_warm = [median(r["warm"]) for r in pick(scene, t, "llvm-avx2")]
                row += [fmt_range(h_warm), f"{median(h_warm) / median(o_rend):.2f}x"]
            scalar = [r["first"] for r in pick(scene, t, "scalar")]
            row += [fmt_range(scalar, 2),
                    f"{median(scalar) / median(o_rend):.1f}x" if scalar else "-",
                    f"{median(o_cpu):.2f}, {median(m_cpu):.2f}",
                    f"{median(m_cpu) / median(o_cpu):.2f}x"]
            print("| " + " | ".join(row) + " |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmds = parser.add_subparsers(dest="command", required=True)
    p = cmds.add_parser("run", help="alternate ours and Mitsuba's renders; print the table")
    p.add_argument("--raytracer", default=os.path.join(ROOT, "target", "release", "raytracer"))
    p.add_argument("--scenes", default=",".join(SCENES))
    p.add_argument("--threads", default="1,2", help="thread counts, comma-separated")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--packet-width", help="ours' --packet-width (default: the binary's own)")
    p.add_argument("--warm", type=int, default=3, help="warm renders a Mitsuba process")
    p.add_argument("--scalar-rounds", type=int, default=1,
                   help="rounds that also run Mitsuba's scalar_rgb variant (slow)")
    p.add_argument("--hold-avx2", choices=["auto", "yes", "no"], default="auto",
                   help="also run Mitsuba held to AVX2 and 8 lanes (auto: if its default differs)")
    p.add_argument("--pictures", help="write Mitsuba's first-round renders here as PNG")
    p.add_argument("--log", help="append every run as a JSON line to this file")
    p = cmds.add_parser("render", help="one Mitsuba process: load, first and warm renders; JSON")
    p.add_argument("scene")
    p.add_argument("--variant", default="llvm_ad_rgb")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--warm", type=int, default=3)
    p.add_argument("--hold-avx2", action="store_true")
    p.add_argument("--png")
    p = cmds.add_parser("summary", help="print the table of a run's --log again")
    p.add_argument("log")
    p = cmds.add_parser("dict", help="print the Mitsuba scene dict of a project scene")
    p.add_argument("scene")
    args = parser.parse_args()
    try:
        if args.command == "run":
            return run_main(args)
        if args.command == "render":
            return render_main(args)
        if args.command == "summary":
            return summary_main(args)
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
        desc, _ = mitsuba_scene(mi, args.scene)
        print(json.dumps(desc, indent=2, default=str))
        return 0
    except SceneError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except subprocess.CalledProcessError as e:
        print(f"error: {' '.join(e.cmd)} exited with {e.returncode}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
