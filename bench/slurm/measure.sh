#!/usr/bin/env bash
# The figures of docs/cluster.md on a one-node Slurm started here (tests/slurm/local_slurm.sh):
# the per-task overhead of a rayclass process (a 1-pixel crop: process start, OpenCL platform,
# scene load, kernels from the program cache), and the wall time of one frame rendered by one
# process and by scripts/slurm-render as 1, 2 and 4 tile tasks (submit to merged image), the
# configurations interleaved, REPS rounds. Prints CSV rows.
#   bench/slurm/measure.sh [SCENE [REPS [WORK]]]
set -uo pipefail

src=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
scene=$(realpath "${1:-$src/scenes/cornell.json}")
reps=${2:-5}
work=${3:-$src/build/slurm-bench}
rayclass=$src/build/rayclass
source "$src/tests/slurm/local_slurm.sh"
export POCL_MAX_PTHREAD_COUNT=${POCL_MAX_PTHREAD_COUNT:-2}
export RAYCLASS_CACHE_DIR=${RAYCLASS_CACHE_DIR:-$src/build/program_cache}
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$src/build/pocl_cache}
out=$work/out
now() { date +%s.%N; }
stat() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time_s'].get(sys.argv[2], 0))" "$@"; }
# The program's build or load, in the render or before it on the device's start-up thread.
build() { python3 -c "import json,sys; t=json.load(open(sys.argv[1]))['time_s']; print(t.get('program_build', 0) + t.get('program_build_thread', 0))" "$1"; }

"$rayclass" render "$scene" -o "$out/warm.exr" -q  # the program cache filled
echo "what,round,tasks,wall_s,scene_load_s,program_build_s,render_s"
for ((r = 0; r < reps; ++r)); do
    t0=$(now)
    "$rayclass" render "$scene" -o "$out/pixel.exr" --crop 0,0,1,1 --stats "$out/pixel.json" -q
    t1=$(now)
    echo "one_pixel_process,$r,1,$(echo "$t1 - $t0" | bc),$(stat "$out/pixel.json" scene_load),$(build "$out/pixel.json"),$(stat "$out/pixel.json" render)"
    t0=$(now)
    "$rayclass" render "$scene" -o "$out/frame.exr" --stats "$out/frame.json" -q
    t1=$(now)
    echo "one_process,$r,1,$(echo "$t1 - $t0" | bc),$(stat "$out/frame.json" scene_load),$(build "$out/frame.json"),$(stat "$out/frame.json" render)"
    for n in 1 2 4; do
        dir=$out/slurm_${n}_$r
        t0=$(now)
        line=$("$src/scripts/slurm-render" "$scene" "$dir" --tiles "$n" --rayclass "$rayclass")
        [[ $line =~ merge:\ job\ ([0-9]+) ]] || fail "slurm-render said '$line'"
        while [[ ! -f $dir/image.exr ]]; do
            state=$(scontrol show job "${BASH_REMATCH[1]}" | grep -o 'JobState=[A-Z]*')
            [[ $state == JobState=FAILED || $state == JobState=CANCELLED ]] && fail "merge $state"
            sleep 0.05
        done
        t1=$(now)
        render=$(python3 -c "import json,glob; print(max(json.load(open(f))['time_s']['render'] for f in glob.glob('$dir/parts/*.json')))")
        echo "slurm_tiles,$r,$n,$(echo "$t1 - $t0" | bc),,,$render"
    done
done
