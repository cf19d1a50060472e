#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# One prepared check of clvox on a lent GPU machine (issue 34): a bundle made
# here, carried there, run there in one command of at most 10 minutes.
#
#   scripts/gpu_check.sh bundle          here: build release, make build/gpu-bundle/
#   scripts/gpu_check.sh run [BUNDLE]    there: tests, reference voxels, benchmark
#
# bundle: clvox, the test programs that run kernels (TESTS below), the shared
# libraries a bare machine with only an NVIDIA driver may lack (everything
# ldd resolves except glibc, libstdc++, libgcc_s and any NVIDIA/CUDA library;
# libOpenCL.so.1 is Debian's ocl-icd loader), the meshes they use, the
# palettes, reference volumes computed here on PoCL (ref/), and, when
# build/gpu-cache holds it or pip can fetch it, a CPU OpenCL driver: the
# pocl-binary-distribution wheel's PoCL (LLVM linked in; about 28 MiB as
# pocl.tar.xz), so the GPU machine can run "CPU alone" and "GPU + CPU".
# GPU_CHECK_POCL=0 leaves it out (the CPU device there is then only the
# machine's own, if it has one).
#
# run: never stops at a failure; every step has its own timeout inside one
# budget (GPU_CHECK_BUDGET seconds, default 470), the benchmark's largest
# case runs only if time is left. Writes at most 6 files to $OUT (default
# build/gpu-out beside the bundle): summary.md (the tables), run.log,
# tests.log, refs.log, bench.jsonl, env.txt. Ends with "N passed, N failed".
# Device of the tests: $CLVOX_DEVICE if set, else the GPU, else (no GPU
# found, said so) the CPU: the plumbing still runs. GPU_CHECK_QUICK=1 makes
# the benchmark's grids small and GPU_CHECK_TESTS="test_a test_b" runs only
# those tests (for trying the script on a CPU).
# docs/testing.md ("GPU check") has the exact device call.
set -u

# Test programs whose checks run kernels against CPU references.
TESTS="test_real_meshes test_ray test_tetra test_surface test_coverage test_winding test_palette_score test_context test_program_cache"
# Meshes of the reference cases and the benchmark (the tests' own are found
# in their sources).
MESHES="elephant-with-holes.off bunny00.off armadillo.off cow.off"
# Reference cases: name|mesh|options. Computed here on PoCL; there the same
# bytes (EXR) and the same voxels (every channel, via clvox convert to npy)
# must come out on every device and on all of them at once.
CASES="
parity|cow.off|-r 128 --inside parity
parity-z|armadillo.off|-r 96 --inside parity --axis z
winding|elephant-with-holes.off|-r 128
winding-abs-y|elephant-with-holes.off|-r 96 --inside winding-abs --axis y
tetra|armadillo.off|-r 96 --method tetra
surface|bunny00.off|-r 128 --mode surface
conservative|armadillo.off|-r 96 --mode conservative
coverage|bunny00.off|-r 96 --oversample 4
coverage-stochastic|cow.off|-r 64 --oversample 3,5 --stochastic --seed 7
palette|cow.off|-r 40 --palette paper46
palette-file|cow.off|-r 32 --palette palettes/blocks.txt --metric outer
"
POCL_WHEEL=pocl_binary_distribution-3.0-py2.py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64.whl
POCL_TAR=pocl-wheel-3.0.tar.xz
# Libraries the machine itself must provide (and does, with any compiler
# runtime), and the driver's own.
SYSTEM_LIBS='^(linux-vdso|ld-linux|libc\.so|libm\.so|libmvec|libpthread|libdl\.so|librt\.so|libutil|libresolv|libstdc\+\+|libgcc_s|libnvidia|libcuda)'

die() { echo "gpu_check: $*" >&2; exit 1; }
here=$(cd "$(dirname "$0")" && pwd)

# ---------------------------------------------------------------- bundle --
bundle() {
    repo=$(cd "$here/.." && pwd)
    if [ ! -f "$repo/Makefile" ] || [ ! -d "$repo/src" ]; then die "bundle runs from the repository (scripts/gpu_check.sh)"; fi
    cd "$repo" || exit 1
    jobs=${JOBS:-2}
    echo "== build (release)"
    make -s -j"$jobs" || die "make failed"
    targets=""
    for t in $TESTS; do targets="$targets build/release/tests/$t"; done
    # shellcheck disable=SC2086 # targets are words
    make -s -j"$jobs" $targets build/release/bench/volume_diff || die "make of the tests failed"
    [ -d data/meshes ] || die "data/meshes missing (scripts/fetch_meshes.sh)"

    B=$repo/build/gpu-bundle
    rm -rf "$B"
    mkdir -p "$B/bin" "$B/tests" "$B/lib" "$B/data/meshes" "$B/ref" || exit 1
    cp build/release/clvox build/release/bench/volume_diff "$B/bin/"
    for t in $TESTS; do cp "build/release/tests/$t" "$B/tests/"; done
    cp "$here/gpu_check.sh" "$B/gpu_check.sh" && chmod +x "$B/gpu_check.sh"
    cp -r palettes "$B/palettes"
    # Debug info is most of their size (symbols stay, for backtraces).
    strip --strip-debug "$B"/bin/* "$B"/tests/*

    echo "== shared libraries"
    for f in "$B"/bin/* "$B"/tests/*; do ldd "$f"; done | awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' | sort -u |
        while read -r soname path; do
            if echo "$soname" | grep -Eq "$SYSTEM_LIBS"; then continue; fi
            cp -L "$path" "$B/lib/$soname" && strip --strip-debug "$B/lib/$soname" && echo "  $soname <- $path"
        done
    grep -q OCL_ICD_VENDORS "$B/lib/libOpenCL.so.1" 2>/dev/null ||
        echo "warning: the bundled libOpenCL.so.1 is not ocl-icd (OCL_ICD_VENDORS will not work)"

    echo "== meshes"
    names=$MESHES
    for t in $TESTS; do
        names="$names $(grep -oE '"[A-Za-z0-9_-]+\.off"' "tests/$t.c" | tr -d '"')"
    done
    # test_tetra names its meshes without the extension.
    names="$names $(sed -n 's/.*names\[\] = {\(.*\)};.*/\1/p' tests/test_tetra.c | grep -oE '"[A-Za-z0-9_-]+"' | tr -d '"' | sed 's/$/.off/')"
    for m in $(echo "$names" | tr ' ' '\n' | sort -u); do
        if [ -f "data/meshes/$m" ]; then cp "data/meshes/$m" "$B/data/meshes/"; fi
    done
    du -sh "$B/data/meshes" | awk '{print "  " $1 " in " n " files"}' n="$(find "$B/data/meshes" -type f | wc -l)"

    echo "== references (this machine's default device)"
    export POCL_CACHE_DIR="$repo/build/pocl-cache" CLVOX_CACHE_DIR="$repo/build/clvox-cache"
    mkdir -p "$POCL_CACHE_DIR"
    tmp=$(mktemp -d) || exit 1
    (cd "$B" && bin/clvox --list-devices) > "$B/ref/devices.txt" 2>&1
    : > "$B/ref/sums.txt"
    echo "$CASES" | while IFS='|' read -r name mesh opts; do
        [ -n "$name" ] || continue
        # shellcheck disable=SC2086 # opts are words
        if ! (cd "$B" && bin/clvox "data/meshes/$mesh" $opts -q -o "ref/$name.exr"); then
            echo "  $name: FAILED here, left out"; continue
        fi
        exr=$(sha256sum "$B/ref/$name.exr" | cut -d' ' -f1)
        vox=$(voxel_sum "$B/bin/clvox" "$B/ref/$name.exr" "$tmp") || { echo "  $name: convert failed"; continue; }
        echo "$name $exr $vox" >> "$B/ref/sums.txt"
        echo "  $name: $(cd "$B" && bin/clvox info "ref/$name.exr" | grep -iE '^filled' | head -n 1)"
    done
    rm -rf "$tmp"

    echo "== PoCL (CPU device for the GPU machine)"
    if [ "${GPU_CHECK_POCL:-1}" = 0 ]; then
        echo "  left out (GPU_CHECK_POCL=0)"
    else
        pocl_tar "$repo/build/gpu-cache" && cp "$repo/build/gpu-cache/$POCL_TAR" "$B/" ||
            echo "  not bundled: the GPU machine's CPU device is then only its own OpenCL CPU driver, if any"
    fi

    {
        echo "clvox gpu bundle"
        echo "made: $(date -u '+%Y-%m-%d %H:%M:%S UTC') on $(uname -n)"
        echo "commit: $(git rev-parse HEAD 2>/dev/null)$(git diff --quiet 2>/dev/null || echo ' (with uncommitted changes)')"
        echo "glibc needed: $(for f in "$B"/bin/* "$B"/tests/* "$B"/lib/*; do objdump -T "$f" 2>/dev/null; done | grep -oE 'GLIBC_[0-9.]+' | sort -Vu | tail -n 1)"
        echo "libstdc++ needed: $(for f in "$B"/bin/* "$B"/tests/* "$B"/lib/*; do objdump -T "$f" 2>/dev/null; done | grep -oE 'GLIBCXX_[0-9.]+' | sort -Vu | tail -n 1)"
        echo "references from:"; sed 's/^/  /' "$B/ref/devices.txt"
    } > "$B/MANIFEST.txt"
    cat "$B/MANIFEST.txt"
    size=$(du -sm "$B" | cut -f1)
    echo "== bundle: $B, $(du -sh "$B" | cut -f1) ($(find "$B" -type f | wc -l) files)"
    du -sh "$B"/* | sed 's/^/  /'
    if [ "$size" -gt 50 ]; then echo "warning: over 50 MiB; the device tool carries 64 MiB with the working tree"; fi
}

# voxel_sum CLVOX FILE.exr TMPDIR: one sha256 over the volume's channels
# (clvox convert to npy: every channel, no header), whatever the EXR bytes.
voxel_sum() {
    rm -f "$3"/v*.npy "$3"/v.json
    "$1" convert "$2" "$3/v.npy" >/dev/null 2>&1 || return 1
    cat "$3"/v*.npy | sha256sum | cut -d' ' -f1
}

# pocl_tar CACHE: CACHE/$POCL_TAR from the wheel (CACHE/$POCL_WHEEL, else
# fetched by pip): libpocl (LLVM inside), hwloc, the OpenCL headers and the
# kernel libraries of avx512, avx2 and (any other) sse2 CPUs, laid out as in
# the wheel (libpocl finds hwloc and share/pocl from its own place).
pocl_tar() {
    c=$1
    if [ -f "$c/$POCL_TAR" ]; then echo "  $c/$POCL_TAR (cached)"; return 0; fi
    mkdir -p "$c" || return 1
    if [ ! -f "$c/$POCL_WHEEL" ]; then
        python3 -m pip download --no-deps --only-binary=:all: --platform manylinux2014_x86_64 \
            --python-version 3.12 --implementation cp -d "$c" pocl-binary-distribution==3.0 >/dev/null 2>&1 ||
            { echo "  pip could not fetch pocl-binary-distribution==3.0"; return 1; }
    fi
    x=$(mktemp -d) || return 1
    (cd "$x" && python3 -m zipfile -e "$c/$POCL_WHEEL" .) || { rm -rf "$x"; return 1; }
    s=pocl_binary_distribution/.libs/share/pocl
    echo "  compressing PoCL (xz -9: minutes, once; cached in $c)"
    (cd "$x" && tar -cf - pyopencl/.libs/libpocl-*.so pocl_binary_distribution/.libs/libhwloc-* $s/include \
        $s/kernel-*-avx512.bc $s/kernel-*-avx2.bc $s/kernel-*-sse2.bc) |
        xz -T2 -9 > "$c/$POCL_TAR.part" && mv "$c/$POCL_TAR.part" "$c/$POCL_TAR"
    rc=$?
    rm -rf "$x"
    return $rc
}

# ------------------------------------------------------------------- run --
now() { date +%s; }
left() { echo $((DEADLINE - $(now))); }
log() { echo "$*" | tee -a "$OUT/run.log"; }
PASS=0 FAIL=0 SKIP=0
ROWS=""
# result NAME ok|FAIL|skip SECONDS NOTE: one row of the checks table
result() {
    case $2 in ok) PASS=$((PASS + 1));; FAIL) FAIL=$((FAIL + 1));; *) SKIP=$((SKIP + 1));; esac
    ROWS="$ROWS| $1 | $2 | $3 | $4 |
"
    log "  [$2] $1 ($3 s) $4"
}
# limit WANT: seconds for a step, WANT or what the budget leaves (0: none)
limit() {
    l=$(($(left) - RESERVE))
    [ "$l" -gt "$1" ] && l=$1
    [ "$l" -lt 5 ] && l=0
    echo "$l"
}

run() {
    B=${1:-}
    if [ -z "$B" ]; then
        if [ -x "$here/bin/clvox" ]; then B=$here; else B=$(cd "$here/.." && pwd)/build/gpu-bundle; fi
    fi
    B=$(cd "$B" 2>/dev/null && pwd) || die "no bundle at ${1:-build/gpu-bundle} (scripts/gpu_check.sh bundle)"
    [ -x "$B/bin/clvox" ] || die "$B is not a bundle (no bin/clvox)"
    OUT=${OUT:-$B/../gpu-out}
    mkdir -p "$OUT" || die "cannot make $OUT"
    OUT=$(cd "$OUT" && pwd)
    rm -f "$OUT/summary.md" "$OUT/run.log" "$OUT/tests.log" "$OUT/refs.log" "$OUT/bench.jsonl" "$OUT/env.txt"
    START=$(now)
    DEADLINE=$((START + ${GPU_CHECK_BUDGET:-470}))
    RESERVE=10
    W=$(mktemp -d /tmp/gpu-check.XXXXXX) || die "no temporary directory"
    # shellcheck disable=SC2064 # expand now
    trap "rm -rf '$W'" EXIT
    mkdir -p "$W/vendors" "$W/pocl-cache" "$W/clvox-cache" "$W/test-tmp" "$W/tests" "$W/r" "$W/bench" "$W/npy"
    ln -s "$B/data" "$W/data" && ln -s "$B/palettes" "$W/palettes"
    cd "$W" || exit 1
    log "gpu_check run: bundle $B, output $OUT, budget ${GPU_CHECK_BUDGET:-470} s"
    sed 's/^/  /' "$B/MANIFEST.txt" | tee -a "$OUT/run.log"

    # ---- environment: the bundle's libraries first, the machine's OpenCL drivers
    export LD_LIBRARY_PATH="$B/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    export POCL_CACHE_DIR="$W/pocl-cache" CLVOX_CACHE_DIR="$W/clvox-cache" CLVOX_TEST_TMP="$W/test-tmp"
    export CLVOX_BIN="$B/bin/clvox"
    for f in /etc/OpenCL/vendors/*.icd; do [ -f "$f" ] && cp "$f" "$W/vendors/"; done
    if ! cat "$W"/vendors/*.icd 2>/dev/null | grep -q nvidia; then
        # CUDA images often have the driver's libnvidia-opencl but no .icd naming it.
        nv=""
        for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib \
                 $(ldconfig -p 2>/dev/null | awk '/libnvidia-opencl\.so/ {print $NF}' | xargs -r -n1 dirname); do
            if [ -e "$d/libnvidia-opencl.so.1" ]; then nv=$d/libnvidia-opencl.so.1; break; fi
        done
        if [ -n "$nv" ]; then
            echo "$nv" > "$W/vendors/nvidia-found.icd"
            LD_LIBRARY_PATH="$LD_LIBRARY_PATH:${nv%/*}"
            log "NVIDIA OpenCL driver found without an .icd: $nv"
        fi
    fi
    if [ -f "$B/$POCL_TAR" ]; then
        t0=$(now)
        mkdir -p "$W/pocl"
        if (cd "$W/pocl" && { tar -xJf "$B/$POCL_TAR" 2>/dev/null ||
                python3 -c 'import sys,tarfile; tarfile.open(sys.argv[1]).extractall(".")' "$B/$POCL_TAR"; }); then
            ls "$W"/pocl/pyopencl/.libs/libpocl-*.so > "$W/vendors/pocl-bundled.icd"
            log "bundled PoCL unpacked ($(($(now) - t0)) s)"
        else
            log "bundled PoCL could not be unpacked: no CPU device of our own"
        fi
    fi
    export OCL_ICD_VENDORS="$W/vendors"

    {
        echo "== machine"; uname -a; grep PRETTY_NAME /etc/os-release 2>/dev/null
        echo "glibc: $(ldd --version 2>&1 | head -n 1)"
        grep -m1 'model name' /proc/cpuinfo; echo "cores: $(nproc)"
        command -v nvidia-smi >/dev/null && nvidia-smi -L && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv
        echo "== OpenCL vendors ($OCL_ICD_VENDORS)"
        for f in "$W"/vendors/*.icd; do [ -f "$f" ] && echo "$(basename "$f"): $(cat "$f")"; done
        echo "== LD_LIBRARY_PATH=$LD_LIBRARY_PATH"
        echo "== ldd bin/clvox"; ldd "$B/bin/clvox"
        echo "== ldd tests/test_real_meshes"; ldd "$B/tests/test_real_meshes"
    } > "$OUT/env.txt" 2>&1

    # ---- 1. the bundle's libraries are the ones used, and clvox starts
    t0=$(now); bad=""
    for f in "$B"/lib/*; do
        so=$(basename "$f")
        got=$(ldd "$B/bin/clvox" "$B"/tests/* 2>/dev/null | awk -v s="$so" '$1 == s {print $3}' | sort -u)
        for g in $got; do [ "$g" = "$B/lib/$so" ] || [ "$g" = "$f" ] || bad="$bad $so=>$g"; done
    done
    missing=$(ldd "$B/bin/clvox" "$B"/tests/* 2>/dev/null | grep 'not found' | sort -u | tr -s ' \t' ' ')
    if [ -z "$bad$missing" ]; then result "bundled libraries used" ok $(($(now) - t0)) "$(find "$B/lib" -type f | wc -l) libraries from $B/lib"
    else result "bundled libraries used" FAIL $(($(now) - t0)) "elsewhere:$bad; missing: $missing"; fi
    t0=$(now)
    if v=$("$B/bin/clvox" --version 2>&1); then result "clvox starts" ok $(($(now) - t0)) "$(echo "$v" | head -n 1)"
    else result "clvox starts" FAIL $(($(now) - t0)) "$(echo "$v" | head -n 1)"; fi

    # ---- 2. devices
    t0=$(now)
    "$B/bin/clvox" --list-devices > "$W/devices.txt" 2>&1
    rc=$?
    tee -a "$OUT/run.log" "$OUT/env.txt" < "$W/devices.txt"
    ngpu=$(awk 'NR > 1 && $2 == "gpu"' "$W/devices.txt" | wc -l)
    ncpu=$(awk 'NR > 1 && $2 == "cpu"' "$W/devices.txt" | wc -l)
    ndev=$(awk 'NR > 1 && $1 ~ /^[0-9]+$/' "$W/devices.txt" | wc -l)
    if [ "$rc" -eq 0 ] && [ "$ndev" -gt 0 ]; then result "list devices" ok $(($(now) - t0)) "$ngpu GPU, $ncpu CPU, $ndev in all"
    else result "list devices" FAIL $(($(now) - t0)) "exit $rc, $ndev devices"; fi
    if [ "$ngpu" -eq 0 ]; then
        log "NO GPU FOUND: everything runs on the CPU devices found (this proves the plumbing, not the GPU)"
    fi
    if [ -n "${CLVOX_DEVICE:-}" ]; then DEV=$CLVOX_DEVICE
    elif [ "$ngpu" -gt 0 ]; then DEV=gpu
    else DEV=cpu; fi
    export CLVOX_DEVICE="$DEV"
    # The devices the references and the benchmark run on: the tests' device,
    # the CPU alone, all at once.
    DEVS=$DEV
    [ "$ngpu" -gt 0 ] && [ "$DEV" != gpu ] && DEVS="$DEVS gpu"
    [ "$ncpu" -gt 0 ] && [ "$DEV" != cpu ] && DEVS="$DEVS cpu"
    [ "$ndev" -gt 1 ] && DEVS="$DEVS all"
    log "tests on --device $DEV; references and benchmark on: $DEVS"

    # ---- 3. the test programs (kernels against CPU references)
    log "== tests"
    tp=0 tf=0
    for t in ${GPU_CHECK_TESTS:-$TESTS}; do
        [ -x "$B/tests/$t" ] || continue
        l=$(limit 150)
        if [ "$l" -eq 0 ]; then result "$t" skip 0 "no time left"; continue; fi
        t0=$(now)
        timeout -k 5 "$l" "$B/tests/$t" > "$W/tests/$t.log" 2>&1
        rc=$?
        { echo "==== $t (exit $rc, $(($(now) - t0)) s, device $DEV)"; tail -c 2000000 "$W/tests/$t.log"; } >> "$OUT/tests.log"
        line=$(grep -E '^[0-9]+ passed, [0-9]+ failed$' "$W/tests/$t.log" | tail -n 1)
        p=${line%% passed*}; f=${line#*passed, }; f=${f%% failed}
        if [ -z "$line" ]; then p=0 f=1; fi
        tp=$((tp + p)); tf=$((tf + f))
        skips=$(grep -ci '^skip' "$W/tests/$t.log")
        if [ "$rc" -eq 0 ] && [ -n "$line" ] && [ "$f" -eq 0 ]; then result "$t" ok $(($(now) - t0)) "$line${skips:+, $skips skip lines}"
        elif [ "$rc" -ge 124 ] && [ -z "$line" ]; then result "$t" FAIL $(($(now) - t0)) "timed out after $l s"
        else result "$t" FAIL $(($(now) - t0)) "exit $rc: ${line:-no summary line}; $(grep -m1 -E 'FAIL|error' "$W/tests/$t.log" | cut -c1-160)"; fi
    done
    log "tests: $tp checks passed, $tf failed"

    # ---- 4. reference volumes: the same bytes and voxels as PoCL here
    log "== references"
    while read -r name exr vox; do
        spec=$(echo "$CASES" | grep "^$name|")
        mesh=$(echo "$spec" | cut -d'|' -f2); opts=$(echo "$spec" | cut -d'|' -f3)
        for d in $DEVS; do
            l=$(limit 60)
            if [ "$l" -eq 0 ]; then result "ref $name --device $d" skip 0 "no time left"; continue; fi
            o="$W/r/$name.$d.exr"; t0=$(now)
            # shellcheck disable=SC2086 # opts are words
            timeout -k 5 "$l" "$B/bin/clvox" "data/meshes/$mesh" $opts --device "$d" -q -o "$o" >> "$OUT/refs.log" 2>&1
            rc=$?
            if [ "$rc" -ne 0 ]; then result "ref $name --device $d" FAIL $(($(now) - t0)) "exit $rc"; continue; fi
            gx=$(sha256sum "$o" | cut -d' ' -f1)
            gv=$(voxel_sum "$B/bin/clvox" "$o" "$W/npy")
            if [ "$gv" != "$vox" ]; then
                ch=occupancy
                case $opts in *--palette*) ch=element;; *--oversample*) ch=coverage;; esac
                diff=$("$B/bin/volume_diff" "$B/ref/$name.exr" "$o" "$ch" 2>&1)
                result "ref $name --device $d" FAIL $(($(now) - t0)) "voxels differ: $ch $diff"
            elif [ "$gx" != "$exr" ]; then
                result "ref $name --device $d" FAIL $(($(now) - t0)) "same voxels, EXR bytes differ"
                { echo "== $name $d: header here vs reference"; "$B/bin/clvox" info "$o"; "$B/bin/clvox" info "$B/ref/$name.exr"; } >> "$OUT/refs.log" 2>&1
            else
                result "ref $name --device $d" ok $(($(now) - t0)) "same bytes"
            fi
            rm -f "$o"
        done
    done < "$B/ref/sums.txt"

    # ---- 5. benchmark: GPU alone, CPU alone, all
    log "== benchmark"
    if [ "${GPU_CHECK_QUICK:-0}" = 1 ]; then
        BENCH="elephant-with-holes.off|-r 96|40
bunny00.off|-r 96 --oversample 2|60
armadillo.off|-r 192|80"
    else
        BENCH="elephant-with-holes.off|-r 256|60
bunny00.off|-r 512 --oversample 4|120
armadillo.off|-r 2048|150"
    fi
    BROWS=""
    while IFS='|' read -r mesh opts want; do
        first=""
        for d in $DEVS; do
            l=$(limit "$want")
            if [ "$l" -lt "$want" ]; then
                BROWS="$BROWS| $mesh $opts | $d | skipped: ${l} s left of the budget | | | | |
"
                log "  skip $mesh $opts --device $d: only $l s left"; SKIP=$((SKIP + 1)); continue
            fi
            o="$W/bench/b.exr"; rm -f "$o"
            s0=$(date +%s.%N)
            # shellcheck disable=SC2086 # opts are words
            timeout -k 5 "$l" "$B/bin/clvox" "data/meshes/$mesh" $opts --device "$d" --json -o "$o" > "$W/bench/j" 2> "$W/bench/e"
            rc=$?
            s1=$(date +%s.%N)
            wall=$(awk -v a="$s0" -v b="$s1" 'BEGIN {printf "%.2f", b - a}')
            cat "$W/bench/j" >> "$OUT/bench.jsonl"
            if [ "$rc" -ge 124 ] && [ ! -s "$W/bench/j" ]; then
                BROWS="$BROWS| $mesh $opts | $d | timeout ($l s) | | | | |
"
                log "  $mesh $opts --device $d: timed out after $l s"; SKIP=$((SKIP + 1)); continue
            fi
            f=$(json_fields < "$W/bench/j")
            if [ "$rc" -ne 0 ]; then
                result "bench $mesh $opts --device $d" FAIL "$wall" "exit $rc: $(head -c 200 "$W/bench/e")"
                continue
            fi
            sum=$(sha256sum "$o" | cut -d' ' -f1)
            same="(first)"
            if [ -z "$first" ]; then first=$sum
            elif [ "$sum" = "$first" ]; then same=yes
            else same=NO; fi
            BROWS="$BROWS| $mesh $opts | $d | $wall | $f | $same |
"
            if [ "$same" = NO ]; then result "bench $mesh $opts --device $d" FAIL "$wall" "EXR differs from --device $(echo "$DEVS" | cut -d' ' -f1)"
            else result "bench $mesh $opts --device $d" ok "$wall" "$f"; fi
            rm -f "$o"
        done
    done <<EOF
$BENCH
EOF

    # ---- 5b. launch groups on the GPU (docs/design.md "Several devices"):
    # its default group (compute units x 2048 rays a call) against one slab
    # a call (CLVOX_LAUNCH_SLABS=1, the old launch), interleaved, same bytes
    if [ "$ngpu" -gt 0 ]; then
        log "== launch groups (gpu)"
        lres="-r 1024"
        [ "${GPU_CHECK_QUICK:-0}" = 1 ] && lres="-r 192"
        lsum=""
        for rep in 1 2; do
            for g in 1 default; do
                l=$(limit 60)
                if [ "$l" -eq 0 ]; then log "  skip launch groups: no time left"; SKIP=$((SKIP + 1)); continue; fi
                o="$W/bench/g$g.exr"; rm -f "$o"
                ev=CLVOX_LAUNCH_SLABS=; [ "$g" = 1 ] && ev=CLVOX_LAUNCH_SLABS=1
                s0=$(date +%s.%N)
                # shellcheck disable=SC2086 # lres is words
                env "$ev" timeout -k 5 "$l" "$B/bin/clvox" data/meshes/armadillo.off $lres --device gpu -q -o "$o" 2> "$W/bench/e"
                rc=$?
                wall=$(awk -v a="$s0" -v b="$(date +%s.%N)" 'BEGIN {printf "%.2f", b - a}')
                if [ "$rc" -ne 0 ]; then
                    result "launch armadillo $lres group $g #$rep" FAIL "$wall" "exit $rc: $(head -c 200 "$W/bench/e")"
                    continue
                fi
                sum=$(sha256sum "$o" | cut -d' ' -f1)
                same="(first)"
                if [ -z "$lsum" ]; then lsum=$sum
                elif [ "$sum" = "$lsum" ]; then same="same bytes"
                else same=NO; fi
                if [ "$same" = NO ]; then result "launch armadillo $lres group $g #$rep" FAIL "$wall" "EXR differs from group 1"
                else result "launch armadillo $lres group $g #$rep" ok "$wall" "$same"; fi
            done
        done
    fi

    # ---- summary
    {
        echo "# clvox GPU check"
        echo
        echo "$(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores, $(($(now) - START)) s; tests on --device $DEV"
        [ "$ngpu" -eq 0 ] && echo && echo "**No GPU found**: everything ran on the CPU devices (plumbing only)."
        echo
        echo '```'; cat "$W/devices.txt"; echo '```'
        echo
        echo "| check | result | s | note |"
        echo "|---|---|---|---|"
        printf '%s' "$ROWS"
        echo
        echo "Benchmark (wall: the whole process; clvox s: its own total, load to write; shares: slabs per device)"
        echo
        echo "| case | device | wall s | clvox s | filled voxels | scheduling efficiency | shares | same EXR |"
        echo "|---|---|---|---|---|---|---|---|"
        printf '%s' "$BROWS"
        echo
        echo "$PASS passed, $FAIL failed ($SKIP skipped)"
    } > "$OUT/summary.md"
    cat "$OUT/summary.md" >> "$OUT/run.log"
    log "summary: $OUT/summary.md"
    log "$PASS passed, $FAIL failed"
    [ "$FAIL" -eq 0 ]
}

# json_fields < JSON: "clvox s | filled | efficiency | shares" of one --json line
json_fields() {
    python3 -c '
import json, sys
try:
    j = json.loads(sys.stdin.read())
except Exception:
    print("? | ? | ? | ?"); sys.exit(0)
d = j.get("devices") or []
shares = ", ".join("%s: %s slabs %.2f s" % (x.get("name", "?")[:24], x.get("slabs"), x.get("busy_s") or 0) for x in d)
eff = j.get("scheduling_efficiency")
print("%.2f | %s | %s | %s" % (j.get("seconds", {}).get("total") or 0, j.get("filled_voxels"),
      "%.3f" % eff if eff is not None else "-", shares))
' 2>/dev/null || echo "? | $(grep -o '"filled_voxels":[0-9]*' | cut -d: -f2) | ? | ?"
}

case "${1:-}" in
    bundle) bundle ;;
    run) shift; run "$@" ;;
    *) echo "usage: $0 bundle | run [BUNDLE]" >&2; exit 2 ;;
esac
