#!/usr/bin/env bash
# Render one frame on a Slurm cluster: the parts as one job array (one part a task) and
# the merge as a job that runs only when every part has succeeded.
#
#   deploy/slurm/farm.sh [OPTIONS] SCENE PARTS OUTDIR OUTPUT [-- RAYTRACER-OPTIONS...]
#
#   SCENE    a built-in scene name or a .toml scene file (as `raytracer SCENE` takes it)
#   PARTS    N: the frame is split into N parts (`--region I/N`), array tasks 0 to N-1
#   OUTDIR   directory of the part files (part-I.part) and the jobs' logs (logs/); it
#            must be visible from every node
#   OUTPUT   the merged frame: .exr (linear f32), .png or .ppm
#   RAYTRACER-OPTIONS   passed to every part: --spp, --width, --seed, --sampler,
#            --packet-width, ...
#
# Options:
#   --tasks LIST         array indices to submit (default 0-(N-1)); `--tasks 2` renders
#                        part 2 again, and the merge then takes the parts already there
#   --cpus-per-task C    cores a part (default 1); each part runs `--threads C`
#   --raytracer PATH     the raytracer binary, on every node (default: `raytracer`)
#   --sbatch ARGS        more sbatch options for both jobs, e.g. "--partition=render"
#   --no-merge           submit the parts only
#
# Prints `parts=JOBID merge=JOBID` on stdout. Paths are made absolute before submitting.
set -euo pipefail

usage() {
  sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//' >&2
  exit 2
}

tasks="" cpus=1 raytracer=raytracer sbatch_extra="" merge=1
while [ $# -gt 0 ]; do
  case $1 in
    --tasks) tasks=${2:?--tasks needs a value}; shift 2 ;;
    --cpus-per-task) cpus=${2:?--cpus-per-task needs a value}; shift 2 ;;
    --raytracer) raytracer=${2:?--raytracer needs a value}; shift 2 ;;
    --sbatch) sbatch_extra=${2?--sbatch needs a value}; shift 2 ;;
    --no-merge) merge=0; shift ;;
    -h | --help) usage ;;
    --) break ;;
    -*) echo "farm.sh: unknown option $1" >&2; usage ;;
    *) break ;;
  esac
done
[ $# -ge 4 ] || usage
scene=$1 parts=$2 outdir=$3 output=$4
shift 4
[ "${1:-}" != "--" ] || shift
case $parts in
  '' | *[!0-9]* | 0) echo "farm.sh: PARTS must be a positive number, got '$parts'" >&2; exit 2 ;;
esac
case $cpus in
  '' | *[!0-9]* | 0) echo "farm.sh: --cpus-per-task must be a positive number, got '$cpus'" >&2; exit 2 ;;
esac
tasks=${tasks:-0-$((parts - 1))}

# Absolute paths: the jobs may start in another directory, on another node.
abs() { realpath -m -- "$1"; }
outdir=$(abs "$outdir")
output=$(abs "$output")
case $scene in */* | *.toml) scene=$(abs "$scene") ;; esac
case $raytracer in */*) raytracer=$(abs "$raytracer") ;; esac
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$outdir/logs"

# shellcheck disable=SC2086 # $sbatch_extra is a list of options
parts_job=$(sbatch --parsable $sbatch_extra \
  --job-name=raytracer-parts \
  --array="$tasks" \
  --cpus-per-task="$cpus" \
  --output="$outdir/logs/part-%a.log" \
  "$here/part.sbatch" "$raytracer" "$scene" "$parts" "$outdir" "$@")
parts_job=${parts_job%%;*}
merge_job=none
if [ "$merge" = 1 ]; then
  # shellcheck disable=SC2086
  merge_job=$(sbatch --parsable $sbatch_extra \
    --job-name=raytracer-merge \
    --dependency="afterok:$parts_job" \
    --kill-on-invalid-dep=yes \
    --output="$outdir/logs/merge.log" \
    "$here/merge.sbatch" "$raytracer" "$parts" "$outdir" "$output")
  merge_job=${merge_job%%;*}
fi
echo "parts=$parts_job merge=$merge_job"
echo "farm.sh: $scene in $parts parts (tasks $tasks) as job $parts_job, merge job $merge_job -> $output" >&2
