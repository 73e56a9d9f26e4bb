#!/usr/bin/env bash
# scripts/slurm-render on a real one-node Slurm started here: munged, slurmctld and slurmd with
# their configuration, keys, state and logs in WORK (the build tree), stopped at the end whatever
# happens. Checks, byte for byte against one-process renders (every AOV), tiles of the default
# scene and of a bench scene, the frames of an animation, a task that fails once and is requeued,
# and a tile that never arrives (the merge job fails naming it and writes nothing).
#   slurm_test.sh SOURCE_DIR BINARY WORK
# Exit 77 (skipped) where Slurm cannot be started: not root, or the daemons are not installed.
set -uo pipefail

src=$1 rayclass=$2 work=$3
source "$(dirname "${BASH_SOURCE[0]}")/local_slurm.sh"

export POCL_MAX_PTHREAD_COUNT=${POCL_MAX_PTHREAD_COUNT:-2}
export RAYCLASS_CACHE_DIR=${RAYCLASS_CACHE_DIR:-$work/program_cache}
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$work/pocl_cache}
aovs=(--aov depth,id,normal)
cornell=$src/scenes/cornell.json
bench=$src/scenes/bench/sibenik.json
orbit=$src/scenes/cornell_orbit.json
out=$work/out

# One-process renders: the oracle.
"$rayclass" render "$cornell" -o "$out/cornell.exr" --width 96 --height 72 "${aovs[@]}" -q &&
    "$rayclass" render "$bench" -o "$out/sibenik.exr" --width 80 --height 60 "${aovs[@]}" -q &&
    "$rayclass" render "$orbit" -o "$out/orbit.exr" --frames 4:6 --width 64 --height 48 \
        "${aovs[@]}" -q || fail "one-process renders"

submit() {  # submit NAME ARGS...: slurm-render's job ids into ${jobs[NAME]}
    local name=$1 line
    shift
    line=$("$src/scripts/slurm-render" "$1" "$2" --rayclass "$rayclass" "${@:3}") ||
        fail "slurm-render $name"
    echo "$name: $line"
    [[ $line =~ job\ array\ ([0-9]+).*merge:\ job\ ([0-9]+) ]] || fail "slurm-render said '$line'"
    array[$name]=${BASH_REMATCH[1]}
    merge[$name]=${BASH_REMATCH[2]}
}
declare -A array merge
RAYCLASS_SLURM_TEST_FAIL_ONCE=1 submit cornell "$cornell" "$out/cornell" --tiles 4 -- \
    --width 96 --height 72 "${aovs[@]}"
submit sibenik "$bench" "$out/sibenik" --tiles 4 -- --width 80 --height 60 "${aovs[@]}"
submit orbit "$orbit" "$out/orbit" --tiles 2 --frames 4:6 -- --width 64 --height 48 "${aovs[@]}"
RAYCLASS_SLURM_TEST_LOSE=2 submit lost "$cornell" "$out/lost" --tiles 4 -- \
    --width 96 --height 72 "${aovs[@]}"

# Until every job has ended (the requeued task waits out its begin time).
for _ in $(seq 400); do
    [[ -z $(squeue -h -o %i) ]] && break
    sleep 0.5
done
[[ -z $(squeue -h -o %i) ]] || fail "jobs still queued: $(squeue -o '%i %T %r')"

state() { scontrol show job "$1" | grep -o 'JobState=[A-Z_]*' | head -n 1; }
restarts() { scontrol show job "$1" | grep -o 'Restarts=[0-9]*' | head -n 1; }

for name in cornell sibenik; do
    [[ $(state "${merge[$name]}") == JobState=COMPLETED ]] || fail "$name merge: $(state "${merge[$name]}")"
    cmp "$out/$name/image.exr" "$out/$name.exr" || fail "$name: merged tiles differ from one process"
done
for f in 4 5 6; do
    frame=$(printf 'frame_%04d.exr' $f)
    cmp "$out/orbit/$frame" "$(printf '%s/orbit_%04d.exr' "$out" $f)" || fail "orbit $frame differs"
done
# The task that failed once ran twice and still gave the exact image.
[[ $(restarts "${array[cornell]}_1") == Restarts=1 ]] ||
    fail "task 1 not requeued once: $(restarts "${array[cornell]}_1")"
[[ $(restarts "${array[cornell]}_0") == Restarts=0 ]] || fail "task 0 restarted"
grep -q 'attempt 2' "$out"/cornell/logs/task_*_1.log || fail "no second attempt of task 1 logged"
# The lost tile: the merge job fails naming it, and writes no image.
[[ $(state "${merge[lost]}") == JobState=FAILED ]] || fail "lost-tile merge: $(state "${merge[lost]}")"
grep -q "task 2: $out/lost/parts/tile_0002.exr" "$out"/lost/logs/merge_*.log ||
    fail "the merge log does not name tile 2: $(cat "$out"/lost/logs/merge_*.log)"
[[ -z $(ls -A "$out/lost" | grep -v -e '^parts$' -e '^logs$') ]] || fail "the failed merge wrote $(ls "$out/lost")"
echo "PASS: tiles, frames, requeue and a missing tile on Slurm $(sinfo -V | cut -d' ' -f2)"
