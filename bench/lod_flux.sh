#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# What nebrender's default level of detail (--lod 2) changes against full resolution
# (--lod 0), and what it costs: on thick dust (the error table's thick cloud, tau_V ~30
# through the centre), thinner clouds of the same shape and every nebgen preset, at RES^3
# (128), each lit by nebillum and rendered at IMAGE (128x128) from nebrender's default view.
# Per scene: the flux error of the default frame per channel (R G B, bench/exr_compare's
# flux_error against the --lod 0 frame), its render time (the "render" figure of nebrender
# -v, median of RUNS) and its samples, and the same for --lod 0. With BEFORE=path/to/nebrender
# (another build's, e.g. a copy made before a change) the default frame is also rendered with
# that one, back to back with this build's, on the same input: its flux error, time and
# samples, and the time ratio after / before.
#
#   bench/lod_flux.sh                                  # every scene
#   SCENES="thick reflection" BEFORE=/tmp/nebrender-old bench/lod_flux.sh
# Environment: BIN (build/tools), COMPARE (build/bench/exr_compare), RES (128), IMAGE
#   (128x128), RUNS (3), SCENES, RENDER_FLAGS (more nebrender options for every frame),
#   BEFORE, KEEP=1 keeps the temp dir.
set -euo pipefail
SCRIPT=lod_flux.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
BIN=${BIN:-$root/build/tools}
COMPARE=${COMPARE:-$root/build/bench/exr_compare}
RES=${RES:-128}
IMAGE=${IMAGE:-128x128}
RUNS=${RUNS:-3}
SCENES=${SCENES:-"thick filaments moderate thin fbm box reflection external pillars bubble globule bipolar hii"}
BEFORE=${BEFORE:-}
read -r -a rflags <<<"${RENDER_FLAGS:-}"
bench_require "$BIN/nebgen" "$BIN/nebillum" "$BIN/nebrender" "$COMPARE"
[[ -z $BEFORE ]] || bench_require "$BEFORE"
bench_tmpdir

echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg); ${RES}^3, ${IMAGE}, median of $RUNS"

# render EXE NAME FLAGS...: renders lit.vdb into NAME.exr; prints "seconds samples" (the
# median render time of RUNS runs, nebrender -v's "render X s", and the samples).
render() {
    local exe=$1 name=$2; shift 2
    local times=() samples=0 r line
    for ((r = 0; r < RUNS; ++r)); do
        timed "$name" "$exe" -i lit.vdb --res "$IMAGE" --no-png -v "${rflags[@]}" "$@" -o "$name.exr"
        line=$(grep -E '^nebrender: scene .* render ' "$name.log")
        times+=("$(sed -E 's/.* render ([0-9.e+-]+) s.*/\1/' <<<"$line")")
        samples=$(sed -E 's/.* rays, ([0-9]+) samples.*/\1/' <<<"$line")
    done
    printf '%s %s\n' "$(printf '%s\n' "${times[@]}" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }')" "$samples"
}

# flux REF TEST: the flux errors R G B of TEST.exr against REF.exr, in per cent.
flux() {
    "$COMPARE" "$1.exr" "$2.exr" |
        awk '$1 == "R" || $1 == "G" || $1 == "B" { printf "%+.2f ", 100 * $4 }'
}

header="scene            lod0 [s] samples    default: R G B flux vs lod0 [%]    [s]  samples"
[[ -z $BEFORE ]] || header+="   | before: R G B flux [%]             [s]  samples  after/before"
echo "$header"
for scene in $SCENES; do
    case $scene in
        thick) gen=(--emission 0 --density 160000) ;;
        filaments) gen=(--emission 0 --density 60000 --exponent 3 --contrast 4 --frequency 2.5) ;;
        moderate) gen=(--emission 0 --density 16000) ;;
        thin) gen=(--emission 0 --density 600) ;;
        *) gen=(--preset "$scene") ;;
    esac
    timed gen "$BIN/nebgen" --res "$RES" -q "${gen[@]}" -o cloud.vdb
    timed illum "$BIN/nebillum" -i cloud.vdb -o lit.vdb
    read -r t0 s0 < <(render "$BIN/nebrender" full --lod 0)
    [[ -z $BEFORE ]] || read -r tb sb < <(render "$BEFORE" before)
    read -r ta sa < <(render "$BIN/nebrender" after)
    line=$(printf '%-16s %8s %9s    %-30s %8s %9s' "$scene" "$t0" "$s0" "$(flux full after)" "$ta" "$sa")
    if [[ -n $BEFORE ]]; then
        line+=$(printf '   | %-30s %8s %9s  %6.2f' "$(flux full before)" "$tb" "$sb" \
            "$(awk -v a="$ta" -v b="$tb" 'BEGIN { print a / b }')")
    fi
    echo "$line"
done
