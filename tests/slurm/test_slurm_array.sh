#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs examples/slurm/submit.sh on a private one-node Slurm cluster on localhost.
#
#   test_slurm_array.sh TOOLS_DIR WORK_DIR
#
# TOOLS_DIR: where the tools are, as TOOLS_DIR/<tool> or TOOLS_DIR/<tool>/<tool> (or
# TOOLS_DIR/../<tool>/<tool>, as CTest's $<TARGET_FILE_DIR:nebgen> gives). WORK_DIR is created
# if needed; one left by an earlier run (it holds .slurm-test) is emptied first, any other
# non-empty one is refused.
#
# Everything lives in WORK_DIR: a munge key and munged on its own socket, a generated
# slurm.conf (SLURM_CONF points every Slurm command at it; ports picked free among the high
# ones; state, spool, pid and log files), slurmctld and slurmd (node "nebnode", 127.0.0.1,
# the CPUs `slurmd -C` reports). Nothing of the system's Slurm or munge setup is used or
# touched, and no systemd. (Only when WORK_DIR's path is too long for a Unix socket name do
# munge's socket and slurmd's spool go to a short folder under /tmp, removed at the end.)
#
# Then: a tiny scene (nebgen --res 24, nebillum), a 5-frame camera path, and submit.sh with
# FRAMES=5 CHUNK=2 (3 array tasks) and RENDER_FLAGS="--res 32x18"; once both jobs have ended
# (SLURM_TEST_TIMEOUT seconds at most, default 90), the checks: every task and the tone job
# COMPLETED with exit code 0, EXRs f.0001..f.0005 (non-empty, no f.0006), the tone job's PNGs,
# each task's log names its own frames and only those, and the tone job started after every
# array task had ended (by the scripts' clocks and by Slurm's StartTime/EndTime).
# Alongside, examples/slurm/scatter.sbatch runs nebscatter as one job of 2 tasks (MPI ranks,
# srun --mpi=pmix): it must complete, say 2 ranks computed the field, and write the same grid
# checksums as one nebscatter process here (skipped where NEBULA_HAVE_MPI is not ON).
# SLURM_TEST_FRAMES (default 5) submits another frame count, to see the test fail.
#
# Needs root (slurmd runs the jobs; SlurmUser=root) and the Debian packages slurm-wlm and
# munge (slurmctld, slurmd, sbatch, ..., munged); without them it says so and exits 1. On any
# exit a trap cancels the jobs, shuts down the daemons it started and kills what is left of
# their processes (found by this run's SLURM_CONF in their environment). Takes ~15 s.
# Exit 0 when every check passed; 1 otherwise, with the tails of the daemons' and jobs' logs;
# 2: usage error.
set -euo pipefail

usage() { echo "usage: $0 TOOLS_DIR WORK_DIR" >&2; exit 2; }
[[ $# -eq 2 ]] || usage
TOOLS_DIR=$1
WORK_DIR=$2
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
SUBMIT=$(cd "$HERE/../../examples/slurm" && pwd)/submit.sh
T0=$(date +%s)
umask 022

SHOW_LOGS=0 # set once the cluster exists: failures then show its logs
fail() {
    echo "slurm_array: FAIL: $*" >&2
    if ((SHOW_LOGS)); then show_logs >&2; fi
    exit 1
}

# --- what the test needs --------------------------------------------------------------------
[[ -f $SUBMIT ]] || fail "$SUBMIT not found"
export PATH=$PATH:/usr/sbin:/sbin # slurmctld, slurmd and munged live in sbin
missing=()
for cmd in slurmctld slurmd sbatch squeue sinfo scontrol scancel munged; do
    command -v "$cmd" >/dev/null || missing+=("$cmd")
done
if ((${#missing[@]})); then
    fail "missing ${missing[*]}: install Slurm and munge" \
        "(apt-get install -y --no-install-recommends slurm-wlm munge)"
fi
[[ $(id -u) -eq 0 ]] ||
    fail "needs root: slurmd runs the jobs and the private cluster is configured with SlurmUser=root"

[[ -d $TOOLS_DIR ]] || fail "TOOLS_DIR $TOOLS_DIR is not a directory"
TOOLS_DIR=$(cd "$TOOLS_DIR" && pwd)
find_tool() { # find_tool NAME: the executable's absolute path
    local exe
    for exe in "$TOOLS_DIR/$1" "$TOOLS_DIR/$1/$1" "$TOOLS_DIR/../$1/$1"; do
        if [[ -f $exe && -x $exe ]]; then
            echo "$(cd "$(dirname "$exe")" && pwd)/$1"
            return
        fi
    done
    fail "no executable $1 in $TOOLS_DIR (looked for $TOOLS_DIR/$1, $TOOLS_DIR/$1/$1," \
        "$TOOLS_DIR/../$1/$1): build the tools first (make -f Makefile.data tools)"
}
NEBGEN=$(find_tool nebgen)
NEBILLUM=$(find_tool nebillum)
NEBRENDER=$(find_tool nebrender)
NEBTONE=$(find_tool nebtone)
NEBSCATTER=$(find_tool nebscatter)
SCATTER_SBATCH=$(dirname "$SUBMIT")/scatter.sbatch
[[ -f $SCATTER_SBATCH ]] || fail "$SCATTER_SBATCH not found"

mkdir -p "$WORK_DIR" || fail "cannot create $WORK_DIR"
WORK=$(cd "$WORK_DIR" && pwd)
if [[ -e $WORK/.slurm-test ]]; then
    # An earlier run's daemons are gone (its trap stopped them), but be sure before deleting.
    for f in "$WORK"/run/munged.pid "$WORK"/run/slurmctld.pid "$WORK"/run/slurmd.pid; do
        [[ -s $f ]] || continue
        pid=$(<"$f")
        if [[ $pid =~ ^[0-9]+$ ]] && kill -0 "$pid" 2>/dev/null &&
            tr '\0' '\n' <"/proc/$pid/cmdline" 2>/dev/null | grep -q -e munged -e slurm; then
            fail "$WORK: a daemon of an earlier run is still running (pid $pid, $f): stop it first"
        fi
    done
    find "$WORK" -mindepth 1 -delete
elif [[ -n $(ls -A "$WORK") ]]; then
    fail "$WORK is not empty and not an earlier run's folder (no .slurm-test): give an empty or new folder"
fi
: >"$WORK/.slurm-test"
mkdir -p "$WORK/run" "$WORK/log" "$WORK/state" "$WORK/scene" "$WORK/out"
# Unix socket names are limited to 107 bytes: munge's socket and slurmd's spool (where
# slurmstepd puts its sockets) need a short folder.
SOCKDIR=$WORK/run
SHORT_TMP=
if ((${#SOCKDIR} > 60)); then
    SHORT_TMP=$(mktemp -d /tmp/nebslurm.XXXXXX)
    SOCKDIR=$SHORT_TMP
    echo "slurm_array: $WORK is a long path: sockets and slurmd's spool in $SOCKDIR"
fi
mkdir -p "$SOCKDIR/spool"
export SLURM_CONF=$WORK/slurm.conf

# --- stopping what starts here (the trap is set before anything starts) ----------------------
PIDS=()     # daemons started here
JOB_IDS=()  # jobs submitted here
cleanup() {
    local rc=$? pid i
    set +e
    if ((${#JOB_IDS[@]})); then scancel "${JOB_IDS[@]}" >/dev/null 2>&1; fi
    if [[ -n ${CTLD_PID:-} ]] && kill -0 "$CTLD_PID" 2>/dev/null; then
        timeout 10 scontrol shutdown >/dev/null 2>&1 # slurmctld and slurmd
    fi
    for ((i = 0; i < 50; ++i)); do
        local alive=0
        for pid in "${PIDS[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
        ((alive)) || break
        sleep 0.2
    done
    for pid in "${PIDS[@]}"; do kill -TERM "$pid" 2>/dev/null; done
    if [[ -s $WORK/run/munged.pid ]]; then
        pid=$(<"$WORK/run/munged.pid")
        [[ $pid =~ ^[0-9]+$ ]] && kill -TERM "$pid" 2>/dev/null
    fi
    # Whatever is left of this cluster: slurmstepd, job scripts, nebrender. They all carry
    # this run's SLURM_CONF (unique to WORK_DIR) in their environment.
    sleep 0.2
    # shellcheck disable=SC2013 # one pid a word
    for pid in $(grep -l -s -F -x -z "SLURM_CONF=$SLURM_CONF" /proc/[0-9]*/environ | cut -d/ -f3); do
        [[ $pid != "$$" && $pid != "$BASHPID" ]] && kill -KILL "$pid" 2>/dev/null
    done
    for pid in "${PIDS[@]}"; do kill -KILL "$pid" 2>/dev/null; done
    [[ -z $SHORT_TMP ]] || rm -rf "$SHORT_TMP"
    echo "slurm_array: $( ((rc == 0)) && echo PASS || echo "FAIL (exit $rc)") in $(($(date +%s) - T0)) s"
    exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

show_logs() {
    local f
    echo "--- slurm.conf: $SLURM_CONF"
    for f in "$WORK/log/munged.log" "$WORK/log/slurmctld.log" "$WORK/log/slurmctld.stderr" \
        "$WORK/log/slurmd.log" "$WORK/log/slurmd.stderr" "$WORK/log/submit.log" \
        "$WORK"/out/logs/*.log; do
        [[ -f $f ]] || continue
        echo "--- tail of $f"
        tail -n 25 "$f"
    done
    if ((${#JOB_IDS[@]})); then
        echo "--- scontrol show job"
        for f in "${JOB_IDS[@]}"; do scontrol -o show job "$f" 2>&1 | cut -c1-600; done
    fi
    echo "--- sinfo"
    sinfo -N -l 2>&1 | tail -n 5
}

# --- the cluster's configuration ------------------------------------------------------------
# A free TCP port: one no socket of this machine uses now (listening or not), from
# /proc/net/tcp{,6}, random among 20000-59999 so that parallel runs are unlikely to collide.
used_ports() {
    local hex
    awk 'FNR > 1 && split($2, a, ":") == 2 { print a[2] }' /proc/net/tcp /proc/net/tcp6 2>/dev/null |
        while read -r hex; do echo $((16#$hex)); done | sort -u
}
free_port() { # free_port [EXCLUDED]
    local used port i
    used=$(used_ports)
    for ((i = 0; i < 200; ++i)); do
        port=$((20000 + (RANDOM * 32768 + RANDOM) % 40000))
        [[ $port != "${1:-}" ]] || continue
        grep -qx "$port" <<<"$used" || { echo "$port"; return; }
    done
    fail "no free TCP port found"
}
CTLD_PORT=$(free_port)
SLURMD_PORT=$(free_port "$CTLD_PORT")

# The node as slurmd sees it (CPUs, sockets, cores, threads), named nebnode, at 127.0.0.1, so
# that neither the machine's hostname nor its resolution matter; little memory (no job asks).
NODE=nebnode
hw=$(slurmd -C 2>/dev/null | head -n 1) || true
topology=$(tr ' ' '\n' <<<"$hw" | grep -E '^(CPUs|Boards|SocketsPerBoard|CoresPerSocket|ThreadsPerCore)=[0-9]+$' | tr '\n' ' ')
[[ $topology == *CPUs=* ]] || topology="CPUs=$(nproc) "
CPUS=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$topology")

cat >"$SLURM_CONF" <<EOF
# Written by $0: a private one-node cluster for one test run.
ClusterName=nebtest
SlurmctldHost=localhost
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$SOCKDIR/munge.socket
CredType=cred/munge
MailProg=/bin/true
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$SOCKDIR/spool
SlurmctldPidFile=$WORK/run/slurmctld.pid
SlurmdPidFile=$WORK/run/slurmd.pid
SlurmctldLogFile=$WORK/log/slurmctld.log
SlurmdLogFile=$WORK/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=600
KillWait=5
NodeName=$NODE NodeAddr=127.0.0.1 NodeHostname=localhost ${topology}RealMemory=256 State=UNKNOWN
PartitionName=nebtest Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF

# munge: its own key (mode 0400) and socket. --force: the folders' permissions are not the
# system's (munged otherwise refuses e.g. a group-writable parent folder).
dd if=/dev/urandom of="$WORK/run/munge.key" bs=1024 count=1 status=none
chmod 0400 "$WORK/run/munge.key"
SHOW_LOGS=1
munged --force --socket="$SOCKDIR/munge.socket" --key-file="$WORK/run/munge.key" \
    --pid-file="$WORK/run/munged.pid" --log-file="$WORK/log/munged.log" \
    --seed-file="$WORK/run/munged.seed" >"$WORK/log/munged.stderr" 2>&1 ||
    fail "munged did not start: $(cat "$WORK/log/munged.stderr")"
for ((i = 0; i < 50; ++i)); do [[ -S $SOCKDIR/munge.socket ]] && break; sleep 0.1; done
[[ -S $SOCKDIR/munge.socket ]] || fail "munged made no socket $SOCKDIR/munge.socket"

slurmctld -D >"$WORK/log/slurmctld.stderr" 2>&1 &
CTLD_PID=$!
PIDS+=("$CTLD_PID")
slurmd -D -N "$NODE" >"$WORK/log/slurmd.stderr" 2>&1 &
PIDS+=($!)

# Bounded wait until the node is idle.
state=
deadline=$((SECONDS + 30))
while ((SECONDS < deadline)); do
    for pid in "${PIDS[@]}"; do
        kill -0 "$pid" 2>/dev/null || fail "a Slurm daemon (pid $pid) exited while starting"
    done
    state=$(sinfo -h -N -n "$NODE" -o '%T' 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.2
done
[[ $state == idle ]] || fail "node $NODE not idle after 30 s (state '${state:-none}')"
echo "slurm_array: cluster up (ports $CTLD_PORT/$SLURMD_PORT, $CPUS CPUs) after $(($(date +%s) - T0)) s"

# --- the scene, the path and the submission ---------------------------------------------------
(cd "$WORK/scene" && "$NEBGEN" --res 24 --seed 3 -q -o small.vdb && "$NEBILLUM" -i small.vdb -q -o lit.vdb) \
    >"$WORK/log/scene.log" 2>&1 || fail "the scene: $(tail -n 5 "$WORK/log/scene.log")"
JOB_TIMEOUT=${SLURM_TEST_TIMEOUT:-90}
[[ $JOB_TIMEOUT =~ ^[0-9]+$ ]] || fail "SLURM_TEST_TIMEOUT must be seconds, got '$JOB_TIMEOUT'"
FRAMES=${SLURM_TEST_FRAMES:-5} # the path has 5; another value is for trying that the test fails
cat >"$WORK/scene/flight.json" <<'EOF'
{"fps": 4, "keyframes": [
  {"time": 0, "eye": [0, 0, -6], "look_at": [0, 0, 0]},
  {"time": 1, "eye": [3, 0, 0], "look_at": [0, 0, 0]}]}
EOF

(cd "$WORK" && SCENE=scene/lit.vdb CAMERA_PATH=scene/flight.json FRAMES=$FRAMES CHUNK=2 OUT=out \
    RENDER_FLAGS="--res 32x18" CPUS_PER_TASK=1 TIME_LIMIT=5 MOVIE=0 \
    NEBRENDER=$NEBRENDER NEBTONE=$NEBTONE "$SUBMIT") >"$WORK/log/submit.log" 2>&1 ||
    fail "submit.sh failed: $(tail -n 5 "$WORK/log/submit.log")"
ARRAY=$(sed -n 's/^ARRAY_JOB_ID=\([0-9]*\)$/\1/p' "$WORK/log/submit.log")
TONE=$(sed -n 's/^TONE_JOB_ID=\([0-9]*\)$/\1/p' "$WORK/log/submit.log")
[[ -n $ARRAY && -n $TONE ]] || fail "submit.sh printed no job ids: $(cat "$WORK/log/submit.log")"
JOB_IDS=("$ARRAY" "$TONE")
echo "slurm_array: submitted array $ARRAY and tone job $TONE"

# nebscatter as one job of 2 MPI tasks (examples/slurm/scatter.sbatch), and the same field
# from one process here: the two must have the same grid checksums.
SCATTER=
if [[ ${NEBULA_HAVE_MPI:-ON} == ON ]]; then
    SCATTER=$(cd "$WORK" && SCENE=scene/lit.vdb OUT=out/scattered.vdb         SCATTER_FLAGS="--packets 20000" NEBSCATTER=$NEBSCATTER         sbatch --parsable --ntasks=2 --cpus-per-task=1 --time=5         --output="$WORK/out/scatter_%j.log" "$SCATTER_SBATCH") ||
        fail "sbatch $SCATTER_SBATCH failed"
    SCATTER=${SCATTER%%;*}
    JOB_IDS+=("$SCATTER")
    echo "slurm_array: submitted nebscatter job $SCATTER (2 tasks)"
    "$NEBSCATTER" -i "$WORK/scene/lit.vdb" -o "$WORK/scene/scattered_one.vdb" --packets 20000 \
        --threads 1 -q || fail "nebscatter (one process) failed"
else
    echo "slurm_array: nebscatter over 2 tasks skipped: this build has no MPI (NEBULA_WITH_MPI)"
fi

# --- wait for both jobs (JOB_TIMEOUT s at most) ------------------------------------------------
TERMINAL='^(COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY|BOOT_FAIL|DEADLINE|PREEMPTED|SPECIAL_EXIT)$'
field() { # field NAME < "scontrol -o show job" lines: the values of NAME=, one a line
    { grep -o "\(^\| \)$1=[^ ]*" || true; } | sed "s/^ *$1=//"
}
done_=0
deadline=$((SECONDS + JOB_TIMEOUT))
while ((SECONDS < deadline)); do
    jobs=$( (for j in "${JOB_IDS[@]}"; do scontrol -o show job "$j"; done) 2>/dev/null || true)
    states=$(field JobState <<<"$jobs")
    if [[ -n $states ]] && ! grep -qvE "$TERMINAL" <<<"$states"; then
        done_=1
        break
    fi
    sleep 0.5
done
((done_)) || fail "the jobs did not end within $JOB_TIMEOUT s: $(tr '\n' ' ' <<<"$states")"
echo "slurm_array: jobs ended after $(($(date +%s) - T0)) s"

# --- the checks -------------------------------------------------------------------------------
errors=()
check() { errors+=("$*"); echo "slurm_array: check failed: $*" >&2; }

array_jobs=$(scontrol -o show job "$ARRAY")
tone_job=$(scontrol -o show job "$TONE")
K=$(((FRAMES + 1) / 2))
n=$(grep -c 'ArrayTaskId=' <<<"$array_jobs" || true)
((n == K)) || check "array $ARRAY has $n tasks, not $K"
while read -r line; do
    task=$(field ArrayTaskId <<<"$line")
    st=$(field JobState <<<"$line")
    ec=$(field ExitCode <<<"$line")
    [[ $st == COMPLETED && $ec == 0:0 ]] || check "array task $task: $st, exit code $ec"
done <<<"$array_jobs"
st=$(field JobState <<<"$tone_job")
ec=$(field ExitCode <<<"$tone_job")
[[ $st == COMPLETED && $ec == 0:0 ]] || check "tone job $TONE: $st, exit code $ec"

for ((f = 1; f <= 5; ++f)); do
    exr=$(printf '%s/out/frames/f.%04d.exr' "$WORK" "$f")
    png=$(printf '%s/out/display/f.%04d.png' "$WORK" "$f")
    [[ -s $exr ]] || check "no EXR $exr (or empty)"
    [[ -s $png ]] || check "no PNG $png (or empty)"
done
extra=$(find "$WORK/out/frames" -name 'f.*.exr' ! -name 'f.000[1-5].exr' | head -n 3)
[[ -z $extra ]] || check "frames beyond the path: $extra"

# Each task's log: its own frames, written by nebrender (-v: "wrote .../f.NNNN.exr"), and no
# other frame.
last_end=0
for ((task = 0; task < K; ++task)); do
    log=$WORK/out/logs/render_${ARRAY}_$task.log
    if [[ ! -f $log ]]; then check "no log $log"; continue; fi
    first=$((task * 2 + 1)) last=$((task * 2 + 2))
    ((last <= FRAMES)) || last=$FRAMES
    grep -q "task $task: frames $first-$last of $FRAMES\$" "$log" || check "$log does not name frames $first-$last"
    mine=$( (grep -o 'f\.[0-9]\{4\}\.exr' "$log" || true) | sort -u | tr '\n' ' ')
    want=$(for ((f = first; f <= last; ++f)); do printf 'f.%04d.exr ' "$f"; done)
    [[ $mine == "$want" ]] || check "$log names frames '$mine', expected '$want'"
    for ((f = first; f <= last; ++f)); do
        grep -q "wrote .*$(printf 'f.%04d.exr' "$f")" "$log" || check "$log: nebrender did not write frame $f"
    done
    end=$(sed -n 's/^render_frames: end \([0-9.]*\)$/\1/p' "$log" | tail -n 1)
    if [[ -z $end ]]; then check "$log has no end time"; continue; fi
    if awk -v a="$end" -v b="$last_end" 'BEGIN { exit !(a > b) }'; then last_end=$end; fi
done

# The tone job started after the whole array ended: by the scripts' clocks, and by Slurm's.
tone_log=$WORK/out/logs/tone_$TONE.log
if [[ -f $tone_log ]]; then
    start=$(sed -n 's/^tone: start \([0-9.]*\)$/\1/p' "$tone_log")
    if [[ -z $start ]]; then
        check "$tone_log has no start time"
    elif ! awk -v a="$start" -v b="$last_end" 'BEGIN { exit !(a >= b) }'; then
        check "the tone job started at $start, before the array's last task ended ($last_end)"
    fi
else
    check "no log $tone_log"
fi
tone_start=$(field StartTime <<<"$tone_job")
for end in $(field EndTime <<<"$array_jobs"); do
    [[ ! $tone_start < $end ]] || check "Slurm: tone job StartTime $tone_start < array task EndTime $end"
done

# The 2-task field: the job completed, ran as 2 MPI ranks, and wrote the one-process field.
if [[ -n $SCATTER ]]; then
    scatter_job=$(scontrol -o show job "$SCATTER")
    st=$(field JobState <<<"$scatter_job")
    ec=$(field ExitCode <<<"$scatter_job")
    [[ $st == COMPLETED && $ec == 0:0 ]] || check "nebscatter job $SCATTER: $st, exit code $ec"
    log=$WORK/out/scatter_$SCATTER.log
    grep -q "by 2 MPI ranks" "$log" 2>/dev/null || check "$log does not say the field was computed by 2 MPI ranks"
    checksums() { grep -ao '"grids":{[^}]*}' "$1" 2>/dev/null || true; }
    two=$(checksums "$WORK/out/scattered.vdb")
    one=$(checksums "$WORK/scene/scattered_one.vdb")
    if [[ -z $two || -z $one ]]; then
        check "no field checksums in $WORK/out/scattered.vdb or the one-process field"
    elif [[ $two != "$one" ]]; then
        check "the 2-task field's grid checksums differ from one process's"
    elif ! grep -q 'scatter\.stars\.J' <<<"$two"; then
        check "the 2-task output has no scatter.stars.J grids"
    fi
fi

if ((${#errors[@]})); then
    fail "${#errors[@]} check(s) failed: ${errors[0]}"
fi
echo "slurm_array: $K tasks rendered frames 1-$FRAMES, tone job $TONE toned them after the array"
[[ -z $SCATTER ]] || echo "slurm_array: nebscatter job $SCATTER: 2 MPI tasks wrote the one-process field, bit for bit"
