#!/bin/sh
# Submits a split render of SCENE to Slurm: one job tracing the photon maps, a job array
# rendering one tile (or one pass range of a tile) per task, and a merge job that runs only if every tile
# succeeded (afterok; --kill-on-invalid-dep=yes cancels it when a tile fails instead of
# leaving it pending forever). Prints the job ids and the final image's path.
#
#   farm/slurm/submit.sh [--tiles N] [--passes P] [--pass-ranges K] [--cpus-per-task C]
#                        [--array LIST] [--partition P] [--photons N] [--caustic-photons N]
#                        [--overlap X] [--seed S] SCENE OUTDIR [-- RENDER_OPTIONS...]
#
#   --tiles N            tiles, default 4
#   --passes P           progressive passes of the whole render (default: render's default)
#   --pass-ranges K      split each tile's passes into K ranges (K <= P), default 1: the job
#                        array has N x K tasks, task T rendering tile T / K, range T % K
#   --cpus-per-task C    CPUs of each task, passed to photondiff as --threads; default 2
#   --array LIST         only these task indices (e.g. 2 or 1,3): re-runs failed tasks, reusing
#                        OUTDIR/photons.pdm when it exists, then merges all parts again
#   --partition P        Slurm partition (default: the cluster's default)
#   --photons, --caustic-photons, --overlap, --seed, --global-aim, --probe-walls: photon
#                        settings, for the maps and the tiles
#   RENDER_OPTIONS       further `photondiff render` options, e.g. --estimator multisampled;
#                        those that decide the photon maps (--estimator and the photon
#                        settings above) go to the photons job too, so the maps are the ones
#                        the tiles' render would trace
#
# OUTDIR must be on a file system every node sees. Writes OUTDIR/photons.pdm,
# OUTDIR/parts/tile-I-of-N[.passes-A-B].exr, OUTDIR/<scene name>.exr (+ .png, .stats.json) and the jobs'
# logs in OUTDIR/logs. The photondiff binary: $PHOTONDIFF, else photondiff on PATH, else
# target/release/photondiff of this repository.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
tiles=4 passes= ranges=1 cpus=2 array= partition= photon_options=
usage() { sed -n '2,/^set -eu/p' "$0" | sed '$d; s/^# \{0,1\}//' >&2; exit 1; }
while [ $# -gt 0 ]; do
    case $1 in
        --tiles|--passes|--pass-ranges|--cpus-per-task|--array|--partition|--photons|--caustic-photons|--overlap|--seed|--global-aim|--probe-walls)
            [ $# -ge 2 ] || { echo "submit.sh: $1 needs a value" >&2; usage; } ;;
    esac
    case $1 in
        --tiles) tiles=$2; shift 2 ;;
        --passes) passes=$2; shift 2 ;;
        --pass-ranges) ranges=$2; shift 2 ;;
        --cpus-per-task) cpus=$2; shift 2 ;;
        --array) array=$2; shift 2 ;;
        --partition) partition=$2; shift 2 ;;
        --photons|--caustic-photons|--overlap|--seed|--global-aim|--probe-walls)
            photon_options="$photon_options $1 $2"; shift 2 ;;
        -h|--help) usage ;;
        -*) echo "submit.sh: unknown option $1" >&2; usage ;;
        *) break ;;
    esac
done
[ $# -ge 2 ] || usage
scene=$(realpath "$1")
mkdir -p "$2"
out=$(realpath "$2")
shift 2
[ "${1:-}" = "--" ] && shift
# The render options that decide the photon maps, for the photons job as well: maps traced
# with other settings than the tiles' render are refused by `render --photon-maps`.
previous= map_options=
for option in "$@"; do
    case $previous in
        --estimator|--photons|--caustic-photons|--overlap|--seed|--global-aim|--probe-walls)
            map_options="$map_options $previous $option" ;;
    esac
    case $option in
        --estimator=*|--photons=*|--caustic-photons=*|--overlap=*|--seed=*|--global-aim=*|--probe-walls=*)
            map_options="$map_options $option" ;;
    esac
    previous=$option
done
[ -n "$passes" ] || [ "$ranges" = 1 ] || { echo "submit.sh: --pass-ranges needs --passes" >&2; exit 1; }
for n in "$tiles" "${passes:-1}" "$ranges"; do
    case $n in ''|0|*[!0-9]*) echo "submit.sh: --tiles, --passes and --pass-ranges take whole numbers >= 1, got $n" >&2; exit 1 ;; esac
done
[ "$ranges" -le "${passes:-1}" ] || { echo "submit.sh: --pass-ranges $ranges is more than --passes $passes" >&2; exit 1; }
tasks=$((tiles * ranges))
if [ -n "${PHOTONDIFF:-}" ]; then
    photondiff=$(realpath "$PHOTONDIFF")
elif command -v photondiff >/dev/null; then
    photondiff=$(command -v photondiff)
else
    photondiff=$(realpath "$here/../../target/release/photondiff")
fi
[ -x "$photondiff" ] || { echo "submit.sh: no photondiff binary at $photondiff (cargo build --release, or set PHOTONDIFF)" >&2; exit 1; }
stem=$(basename "$scene"); stem=${stem%.*}
maps=$out/photons.pdm parts=$out/parts logs=$out/logs image=$out/$stem.exr
# A new run into an OUTDIR that holds an earlier run's parts would merge them with its own:
# with another pass layout the merge failed after every task had run.
if [ -z "$array" ]; then
    for part in "$parts"/tile-*.exr; do
        if [ -f "$part" ]; then
            echo "submit.sh: $parts holds parts of an earlier run ($(basename "$part")): give a new OUTDIR, or remove them (--array re-runs tasks of that run)" >&2
            exit 1
        fi
    done
fi
mkdir -p "$parts" "$logs"
# sbatch reads % in --output as a pattern (%x: the job's name): a literal one is %%.
log_dir=$(printf '%s\n' "$logs" | sed 's/%/%%/g')
common="--parsable"
[ -n "$partition" ] && common="$common --partition=$partition"

# Photon maps: traced once, unless re-running some tiles with maps already there.
dependency=
if [ -z "$array" ] || [ ! -e "$maps" ]; then
    # shellcheck disable=SC2086 # word splitting of the option lists is intended
    photons_job=$(sbatch $common --cpus-per-task="$cpus" --output="$log_dir/photons-%j.out" \
        "$here/photons.sbatch" "$photondiff" "$scene" "$maps" $photon_options $map_options)
    echo "photons job: $photons_job"
    dependency="--dependency=afterok:$photons_job --kill-on-invalid-dep=yes"
fi
# shellcheck disable=SC2086
tiles_job=$(sbatch $common --cpus-per-task="$cpus" $dependency --array="${array:-0-$((tasks - 1))}" \
    --output="$log_dir/tile-%A_%a.out" \
    "$here/tile.sbatch" "$photondiff" "$scene" "$maps" "$parts" "$tiles" "$ranges" "${passes:-0}" \
    $photon_options "$@")
echo "tile jobs: $tiles_job (array ${array:-0-$((tasks - 1))})"
# shellcheck disable=SC2086
merge_job=$(sbatch $common --cpus-per-task=1 --dependency="afterok:$tiles_job" --kill-on-invalid-dep=yes \
    --output="$log_dir/merge-%j.out" \
    "$here/merge.sbatch" "$photondiff" "$parts" "$tiles" "$image")
echo "merge job: $merge_job"
echo "image: $image"
