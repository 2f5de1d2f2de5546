#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Queues a camera-path fly-through on Slurm: a job array that renders the frames
# (render_frames.sbatch, CHUNK frames per task), then a job that tones them into PNGs
# (tone.sbatch, nebtone over the whole sequence, and a movie if ffmpeg is there) which starts
# only after every array task succeeded.
#
# Usage (from the top of a checkout, on a login node whose folders the compute nodes share):
#   SCENE=out/pyramid.vdb RENDER_FLAGS="--phase out/phase.vdb --levels 5 --res 320x180" \
#   CAMERA_PATH=examples/flythrough.json FRAMES=121 CHUNK=10 OUT=out/slurm \
#       examples/slurm/submit.sh
# queues 13 render tasks (frames 1-10, 11-20, ..., 121-121) and the tone job; it prints both
# job ids, last as ARRAY_JOB_ID=... and TONE_JOB_ID=... lines. Watch with squeue; logs are in
# $OUT/logs (render_ARRAYID_TASK.log, tone_JOBID.log); frames in $OUT/frames, PNGs in
# $OUT/display. Running the same command again after a failure or a cancel renders only the
# frames that are missing (--skip-existing).
#
# Environment (relative paths are made absolute here, so the jobs do not depend on where they
# start):
#   SCENE, CAMERA_PATH, FRAMES   (required) as in render_frames.sbatch; FRAMES for the whole
#                                path is floor(last keyframe time * fps) + 1 (121 for
#                                examples/flythrough.json: 10 s at 12 fps)
#   CHUNK         frames per array task (default 10)
#   OUT           output folder (default out/slurm)
#   RENDER_FLAGS  extra nebrender options (default: none)
#   TONE_FLAGS    extra nebtone options (default: none)
#   NEBRENDER, NEBTONE  the executables (default: nebrender and nebtone on PATH at submission,
#                 else build/tools/<tool> or build/tools/<tool>/<tool>
#                 of this checkout)
#   CPUS_PER_TASK cores per render task (default: the script's #SBATCH --cpus-per-task, 4)
#   TIME_LIMIT    time limit per render task, sbatch --time format (default: the script's, 1 h)
#   SBATCH_ARGS   more sbatch options for both jobs, split on whitespace, e.g.
#                 "--partition=gpu --account=proj42" (default: none)
#   SBATCH        the sbatch executable (default: sbatch)
#   MOVIE, FPS, FFMPEG  reach tone.sbatch as they are (see its top): MOVIE=0, no movie
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
die() {
    echo "submit: error: $*" >&2
    exit 1
}
need() {
    [[ -n ${!1:-} ]] || die "$1 is not set: $2 (see the top of $0)"
}
positive() {
    [[ ${!1} =~ ^[0-9]+$ && ${!1} =~ [1-9] ]] || die "$1 must be a positive integer, got '${!1}'"
}
absolute() { # absolute PATH: PATH made absolute (need not exist)
    case $1 in
    /*) printf '%s\n' "$1" ;;
    *) printf '%s\n' "$(pwd)/$1" ;;
    esac
}
tool() { # tool NAME VALUE: the executable to use, absolute where it is a path
    local name=$1 value=$2 exe
    if [[ -z $value ]]; then
        value=$(command -v "$name") || value=
        for exe in "$HERE/../../build/tools/$name" "$HERE/../../build/tools/$name/$name"; do
            [[ -z $value && -f $exe && -x $exe ]] && value=$(cd "$(dirname "$exe")" && pwd)/$name
        done
        [[ -n $value ]] ||
            die "no $name on PATH nor in build/tools: give its path (${name^^}=/path/to/$name)"
    elif [[ $value == */* ]]; then
        value=$(absolute "$value")
        [[ -x $value ]] || die "${name^^}=$value is not an executable"
    else
        command -v "$value" >/dev/null || die "${name^^}=$value: not found on PATH"
    fi
    printf '%s\n' "$value"
}

need SCENE "give the scene to render (SCENE=out/pyramid.vdb)"
need CAMERA_PATH "give the camera path (CAMERA_PATH=examples/flythrough.json)"
need FRAMES "give the number of frames (FRAMES=121)"
CHUNK=${CHUNK:-10}
OUT=${OUT:-out/slurm}
positive FRAMES
positive CHUNK
FRAMES=$((10#$FRAMES))
CHUNK=$((10#$CHUNK))
[[ -f $SCENE ]] || die "SCENE $SCENE: no such file"
[[ -f $CAMERA_PATH ]] || die "CAMERA_PATH $CAMERA_PATH: no such file"
SBATCH=${SBATCH:-sbatch}
command -v "$SBATCH" >/dev/null || die "no $SBATCH on PATH: is this a Slurm login node?"

SCENE=$(absolute "$SCENE")
CAMERA_PATH=$(absolute "$CAMERA_PATH")
OUT=$(absolute "$OUT")
NEBRENDER=$(tool nebrender "${NEBRENDER:-}")
NEBTONE=$(tool nebtone "${NEBTONE:-}")
RENDER_FLAGS=${RENDER_FLAGS:-}
TONE_FLAGS=${TONE_FLAGS:-}
export SCENE CAMERA_PATH FRAMES CHUNK OUT NEBRENDER NEBTONE RENDER_FLAGS TONE_FLAGS
# Slurm does not create the folders of --output: a job whose log folder is missing fails.
mkdir -p "$OUT/frames" "$OUT/logs" || die "cannot create $OUT/frames and $OUT/logs"

K=$(((FRAMES + CHUNK - 1) / CHUNK))
echo "submit: $NEBRENDER, $NEBTONE"
render_args=(--parsable --export=ALL --array="0-$((K - 1))"
    --output="$OUT/logs/render_%A_%a.log")
[[ -z ${CPUS_PER_TASK:-} ]] || render_args+=(--cpus-per-task="$CPUS_PER_TASK")
[[ -z ${TIME_LIMIT:-} ]] || render_args+=(--time="$TIME_LIMIT")
# SBATCH_ARGS is split on whitespace on purpose.
# shellcheck disable=SC2206
extra=(${SBATCH_ARGS:-})

# --parsable prints "jobid" or "jobid;cluster".
out=$("$SBATCH" "${render_args[@]}" "${extra[@]}" "$HERE/render_frames.sbatch") ||
    die "sbatch of the render array failed"
ARRAY_JOB_ID=${out%%;*}
[[ $ARRAY_JOB_ID =~ ^[0-9]+$ ]] || die "sbatch printed '$out', not a job id"
echo "submit: render array job $ARRAY_JOB_ID: $K tasks of up to $CHUNK frames, frames 1-$FRAMES -> $OUT/frames"

# afterok on an array job: every task must finish with status 0. If one fails, the tone job
# can never start; --kill-on-invalid-dep=yes cancels it then instead of leaving it pending.
out=$("$SBATCH" --parsable --export=ALL --dependency="afterok:$ARRAY_JOB_ID" \
    --kill-on-invalid-dep=yes --output="$OUT/logs/tone_%j.log" "${extra[@]}" \
    "$HERE/tone.sbatch") ||
    die "sbatch of the tone job failed (the render array $ARRAY_JOB_ID is queued; tone later with:" \
        "OUT=$OUT FRAMES=$FRAMES sbatch $HERE/tone.sbatch)"
TONE_JOB_ID=${out%%;*}
[[ $TONE_JOB_ID =~ ^[0-9]+$ ]] || die "sbatch printed '$out', not a job id"
echo "submit: tone job $TONE_JOB_ID after job $ARRAY_JOB_ID -> $OUT/display; logs in $OUT/logs"
echo "ARRAY_JOB_ID=$ARRAY_JOB_ID"
echo "TONE_JOB_ID=$TONE_JOB_ID"
