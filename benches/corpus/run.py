#!/usr/bin/env python3
"""Measures the scene corpus: one thread, widths 1, 4, 8 and 16 alternated, medians.

    cargo build --release
    python3 benches/corpus/run.py [--rounds 5] [--perf] [--only NAME ...]
        [--widths 1,4,8,16] [--binary BIN] [--baseline OTHER_BINARY]

For each scene: the render phase's seconds (`--report`'s `render`) at each width, the
median over rounds, the ratios scalar / 8-wide and 8-wide / 16-wide, the Mrays/s and
the packets' lane occupancies and what went single (`--stats`) at the widest width,
and with `--perf` the three largest functions of that render (`perf record`, self
time). Every run uses
`--sampler independent`; the widths of one scene run back to back, in an order that
turns each round, so a change in the machine's load falls on all of them. With
`--baseline`, another build of the renderer (a copy of an earlier
`target/release/raytracer`) runs the scalar and 8-wide renders in the same rounds,
alternated with this one, and the table gains their ratios. Prints a Markdown table
(docs/performance.md, "The scene corpus") and the machine it ran on.
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.path.join(ROOT, "target", "release", "raytracer")
CORPUS = [
    "sphere-field",
    "glass-cornell",
    "metal-bunny",
    "triangle-light",
    "box-light",
    "bunny-light",
    "lights-over-bunny",
    "big-mesh-far",
    "big-mesh-close",
]
# The built-in scenes, at a width that keeps each within 0.2-2 s on one core.
BUILTIN = [
    ("cornell", 400),
    ("cornell-area-light", 400),
    ("cornell-point-light", 800),
    ("quads", 800),
    ("spheres", 800),
    ("spheres-defocus", 800),
    ("mixed", 800),
    ("bunny", 800),
    ("bunny-closeup", 800),
]
WIDTHS = [1, 4, 8, 16]


def scene_args(name):
    for builtin, width in BUILTIN:
        if builtin == name:
            return [name, "--width", str(width)]
    return [os.path.join(ROOT, "benches", "corpus", name + ".toml")]


def run(name, width, tmp, extra=(), binary=None):
    report = os.path.join(tmp, "report.json")
    args = scene_args(name) + [
        "--threads", "1", "--packet-width", str(width), "--sampler", "independent",
        "-q", "-o", os.path.join(tmp, "out.exr"), "--report", report, *extra,
    ]
    done = subprocess.run([binary or BIN] + args, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(args)} failed:\n{done.stderr}")
    with open(report) as f:
        r = json.load(f)
    return r["seconds"]["render"], r["rays"]["total"], done.stderr


def occupancy(name, width, tmp):
    """The packets' lane occupancies and single-ray counts at `width`, from `--stats`."""
    _, _, err = run(name, width, tmp, ["--stats"])
    line = next((l for l in err.splitlines() if "lane occupancy" in l), "")
    found = dict(re.findall(r"(camera|shadow|secondary) ([0-9.]+%|-)", line))
    visits = re.search(r"at node visits ([0-9.]+%|-)", line)
    single = next((l for l in err.splitlines() if "went single" in l), "")
    return found, visits.group(1) if visits else "-", single.replace("stats: ", "")


def hottest(name, width, tmp, count=3):
    data = os.path.join(tmp, "perf.data")
    args = scene_args(name) + [
        "--threads", "1", "--packet-width", str(width), "--sampler", "independent", "-q",
        "-o", os.path.join(tmp, "out.exr"),
    ]
    subprocess.run(["perf", "record", "-q", "-F", "2000", "-o", data, BIN] + args,
                   check=True, capture_output=True)
    out = subprocess.run(
        ["perf", "report", "-i", data, "--stdio", "--no-children", "--sort", "symbol"],
        check=True, capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"\s*([0-9.]+)%\s+\[\.\]\s+(.*)", line)
        if m:
            symbol = re.split(r"\s{2,}", m.group(2).strip())[0]
            symbol = re.sub(r"<[^<>]*>", "", symbol).split("::")[-1]
            rows.append(f"`{symbol}` {float(m.group(1)):.0f}%")
        if len(rows) == count:
            break
    return ", ".join(rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--perf", action="store_true", help="add the hottest functions")
    parser.add_argument("--only", nargs="*", help="these scenes only")
    parser.add_argument("--baseline", help="another build to compare with, alternated")
    parser.add_argument("--binary", help="the build to measure (default target/release)")
    parser.add_argument("--widths", default=",".join(map(str, WIDTHS)),
                        help="packet widths, comma-separated (1 and 8 among them)")
    a = parser.parse_args()
    widths = [int(w) for w in a.widths.split(",")]
    if 1 not in widths or 8 not in widths:
        sys.exit("--widths must include 1 and 8")
    widest = max(widths)
    global BIN
    BIN = os.path.abspath(a.binary) if a.binary else BIN
    names = CORPUS + [n for n, _ in BUILTIN]
    if a.only:
        names = [n for n in names if n in a.only]
    if not os.path.exists(BIN):
        sys.exit("build first: cargo build --release")
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo")
                if l.startswith("model name")), "?")
    flags = next((l for l in open("/proc/cpuinfo") if l.startswith("flags")), "")
    isa = "AVX-512" if " avx512f" in flags else "AVX2" if " avx2" in flags else "SSE"
    version = subprocess.run([BIN, "--version"], capture_output=True, text=True).stdout
    print(f"CPU: {cpu}, the host shows {isa}; {version.strip()}")
    print(f"load before: {open('/proc/loadavg').read().split()[:3]}")
    with tempfile.TemporaryDirectory() as tmp:
        times = {n: {w: [] for w in widths} for n in names}
        before = {n: {w: [] for w in (1, 8)} for n in names}
        rays = {}
        for r in range(a.rounds):
            turn = r % len(widths)
            order = widths[turn:] + widths[:turn]
            for n in names:
                for w in order:
                    # This build and the baseline take turns at going first.
                    both = a.baseline and w in before[n]
                    if both and r % 2:
                        before[n][w].append(run(n, w, tmp, binary=a.baseline)[0])
                    seconds, count, _ = run(n, w, tmp)
                    times[n][w].append(seconds)
                    rays[n] = count
                    if both and not r % 2:
                        before[n][w].append(run(n, w, tmp, binary=a.baseline)[0])
            print(f"round {r + 1} of {a.rounds}, load {open('/proc/loadavg').read().split()[:3]}",
                  file=sys.stderr)
        print()
        head = "| scene | " + " | ".join("scalar" if w == 1 else f"{w}-wide" for w in widths)
        head += " | scalar / 8-wide |"
        if 16 in widths:
            head += " 8-wide / 16-wide |"
        head += f" {widest}-wide Mrays/s | occupancy camera, shadow, secondary | at node visits |"
        if a.baseline:
            head += " 8-wide, baseline / this | scalar, baseline / this |"
        if a.perf:
            head += f" largest functions ({widest}-wide, self) |"
        print(head)
        print("|" + "---|" * (head.count("|") - 1))
        singles = []
        for n in names:
            med = {w: statistics.median(times[n][w]) for w in widths}
            occ, visits, single = occupancy(n, widest, tmp)
            row = f"| `{n}` | " + " | ".join(f"{med[w]:.3f} s" for w in widths)
            row += f" | {med[1] / med[8]:.2f}x |"
            if 16 in widths:
                row += f" {med[8] / med[16]:.2f}x |"
            row += (f" {rays[n] / med[widest] / 1e6:.1f} "
                    f"| {occ.get('camera', '-')}, {occ.get('shadow', '-')}, "
                    f"{occ.get('secondary', '-')} | {visits} |")
            if a.baseline:
                for w in (8, 1):
                    row += f" {statistics.median(before[n][w]) / med[w]:.2f}x |"
            if a.perf:
                row += f" {hottest(n, widest, tmp)} |"
            print(row)
            if single:
                singles.append(f"- `{n}`: {single}")
        if singles:
            print()
            print("\n".join(singles))
    print()
    print(f"load after: {open('/proc/loadavg').read().split()[:3]}")


if __name__ == "__main__":
    main()
