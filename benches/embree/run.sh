#!/usr/bin/env bash
# Our tracer against Embree 3 on the same rays, one thread, alternating in one run.
#
#   benches/embree/run.sh [ROUNDS] [PASSES] [rays|builds]   (defaults 3, 5, both)
#
# Seven cases. `bunny` and `closeup`: the built-in scenes as they are (a mesh and three
# spheres; Embree gets the spheres as sphere points, in a second BVH of its own).
# `bunny-mesh` and `closeup-mesh`: the same camera rays on the mesh alone (both tracers
# get the same triangles and nothing else). `bunny-light`: `bunny`'s shadow rays on its
# mesh and its point light (ours needs the light's sphere to answer a shadow query, and
# tests it beside the tree; Embree gets the mesh alone, each ray ending just short of
# the light). `big-far` and `big-close`: the camera rays of those two views (800x450,
# 2 samples a pixel) on the bunny subdivided four times, 1 271 808 triangles, alone
# (far, they are smaller than a pixel). Our camera packets run twice: `camera8` through
# the frustum traversal, `camera8-lanes` through the lane-wise one (a render picks per
# tile: lane-wise where the frustum's leaves hold few of the lanes). Each round runs `vs_embree` (ours) then `embree_bench` (Embree) twice on
# each case: with Embree's default intersect context (which says the rays are
# incoherent) and with EMBREE_COHERENT=1 (RTC_INTERSECT_CONTEXT_FLAG_COHERENT, how
# Embree is meant to be given camera packets); each prints every pass and the median
# of its passes. The summary is the median,
# over rounds, of those medians.
#
# Two build cases (`builds`): the tree over the bunny subdivided four times (1 271 808
# triangles, `big-mesh-far.toml`) and five times (5 087 232, `big-mesh-5m.toml`), ours on
# one thread and on two, Embree's `rtcCommitScene` on one (`threads=1`), each a median
# of PASSES builds after an untimed one.
#
# Needs a C compiler and Embree 3 (Debian: `apt-get install libembree-dev`, 3.13.5).
set -euo pipefail
cd "$(dirname "$0")/../.."
rounds=${1:-3}
passes=${2:-5}
only=${3:-both}
work=${TMPDIR:-/tmp}/raytracer-vs-embree
mkdir -p "$work"

if ! [ -e /usr/include/embree3/rtcore.h ]; then
    echo "Embree 3 headers not found: apt-get install libembree-dev" >&2
    exit 2
fi
cc -O3 -march=native -Wall -o "$work/embree_bench" benches/embree/embree_bench.c -lembree3
cargo build --release --example vs_embree
ours=target/release/examples/vs_embree

if [ "$only" != rays ]; then
    builds=("1.27M benches/embree/big-mesh-far.toml" "5M benches/embree/big-mesh-5m.toml")
    blog="$work/builds.txt"
    : >"$blog"
    for r in $(seq "$rounds"); do
        echo "build round $r, load: $(cut -d' ' -f1-3 /proc/loadavg)"
        for c in "${builds[@]}"; do
            read -r n scene <<<"$c"
            "$ours" "$scene" "$work/build-$n.geometry" "$passes" - build | sed "s/^/$n ours /" | tee -a "$blog"
            "$work/embree_bench" "$work/build-$n.geometry" "$passes" build | sed "s/^/$n embree /" | tee -a "$blog"
        done
    done
    echo
    echo "build times, median over $rounds rounds of each run's median, and their range (ms);"
    echo "the ratio is ours on one thread over Embree on one:"
    printf '%-6s %20s %20s %20s %7s\n' case "ours, 1 thread" "ours, 2 threads" "Embree, 1 thread" ratio
    awk '/median/ {
        for (i = 1; i <= NF; i++) if ($i == "median") v = $(i + 1)
        who = $2 == "embree" ? "embree" : $2 $4
        vals[$1, who] = vals[$1, who] " " v
        if (!($1 in seen)) { seen[$1] = 1; order[++n] = $1 }
    }
    function stats(s, out,   a, k, i, j, t) {
        k = split(s, a, " ")
        for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (a[j] + 0 < a[i] + 0) { t = a[i]; a[i] = a[j]; a[j] = t }
        out[1] = k % 2 ? a[(k + 1) / 2] : (a[k / 2] + a[k / 2 + 1]) / 2
        out[2] = a[1]; out[3] = a[k]
    }
    END {
        for (i = 1; i <= n; i++) {
            c = order[i]
            stats(vals[c, "ours1"], o); stats(vals[c, "ours2"], t); stats(vals[c, "embree"], e)
            printf "%-6s %6.0f (%4.0f-%4.0f) %6.0f (%4.0f-%4.0f) %6.0f (%4.0f-%4.0f) %6.2fx\n", c, o[1], o[2], o[3], t[1], t[2], t[3], e[1], e[2], e[3], o[1] / e[1]
        }
    }' "$blog"
    [ "$only" = builds ] && exit 0
fi

# name, scene traced, scene the rays are made in, the set timed (all: every set), and
# whether Embree gets the mesh alone
cases=("bunny bunny bunny all 0" "closeup bunny-closeup bunny-closeup all 0"
    "bunny-mesh benches/embree/bunny-mesh.toml bunny all 1"
    "closeup-mesh benches/embree/bunny-closeup-mesh.toml bunny-closeup all 1"
    "bunny-light benches/embree/bunny-mesh-light.toml bunny shadow8 1"
    "big-far benches/embree/big-mesh-far.toml benches/embree/big-mesh-far.toml all 1"
    "big-close benches/embree/big-mesh-close.toml benches/embree/big-mesh-close.toml all 1")
for c in "${cases[@]}"; do
    read -r n scene rays _ _ <<<"$c"
    "$ours" "$scene" "$work/$n.rays" 0 "$rays" >/dev/null
done

log="$work/log.txt"
: >"$log"
for r in $(seq "$rounds"); do
    echo "round $r, load: $(cut -d' ' -f1-3 /proc/loadavg)"
    for c in "${cases[@]}"; do
        read -r n scene rays set mesh <<<"$c"
        [ "$set" = all ] && set=""
        # shellcheck disable=SC2086 # $set is one word or none
        "$ours" "$scene" "$work/$n.rays" "$passes" "$rays" $set | sed "s/^/$n ours /" | tee -a "$log"
        # shellcheck disable=SC2086
        EMBREE_MESH_ONLY=$mesh "$work/embree_bench" "$work/$n.rays" "$passes" $set |
            sed "s/^/$n embree /" | tee -a "$log"
        # shellcheck disable=SC2086
        EMBREE_COHERENT=1 EMBREE_MESH_ONLY=$mesh "$work/embree_bench" "$work/$n.rays" "$passes" $set |
            sed "s/^/$n coherent /" | tee -a "$log"
    done
done

echo
echo "median over $rounds rounds of each run's median, and their range (Mrays/s, one thread);"
echo "Embree with its default (incoherent) context, and told the rays are coherent;"
echo "the ratio is ours over the faster of the two:"
printf '%-13s %-13s %20s %20s %20s %7s\n' case set ours embree coherent ratio
awk '/median/ {
    for (i = 1; i <= NF; i++) if ($i == "median") v = $(i + 1)
    key = $1 " " $3; sub(/;$/, "", v)
    vals[key, $2] = vals[key, $2] " " v
    if (!(key in seen)) { seen[key] = 1; order[++n] = key }
}
# Median, minimum and maximum of a space-separated list.
function stats(s, out,   a, k, i, j, t) {
    k = split(s, a, " ")
    for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (a[j] + 0 < a[i] + 0) { t = a[i]; a[i] = a[j]; a[j] = t }
    out[1] = k % 2 ? a[(k + 1) / 2] : (a[k / 2] + a[k / 2 + 1]) / 2
    out[2] = a[1]; out[3] = a[k]
}
END {
    for (i = 1; i <= n; i++) {
        split(order[i], p, " ")
        stats(vals[order[i], "ours"], o); stats(vals[order[i], "embree"], e)
        stats(vals[order[i], "coherent"], c)
        best = e[1] > c[1] ? e[1] : c[1]
        printf "%-13s %-13s %6.1f (%4.1f-%4.1f) %6.1f (%4.1f-%4.1f) %6.1f (%4.1f-%4.1f) %6.2fx\n", p[1], p[2], o[1], o[2], o[3], e[1], e[2], e[3], c[1], c[2], c[3], o[1] / best
    }
}' "$log"
