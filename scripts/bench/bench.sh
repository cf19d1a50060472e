#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# clvox performance benchmark (not a test): per-stage seconds, whole-process
# time and peak RSS of build/release/clvox on real meshes at several grid sizes.
#
#   scripts/bench/bench.sh [--quick | --big] [--peers] [--repeat R] [--method ray|tetra|all]
#                    [--peer-timeout S]
#
#   --quick      small subset: armadillo at N = 128, 256 and cow at 256
#   --big        big meshes (issue 10): armadillo 52 k, 832 k, 3.3 M and 13.3 M
#                triangles (subdivided 0, 2, 3, 4 times) at N = 512 and 1024,
#                ray method, default inside test (winding) and --inside parity;
#                with --peers, one table of clvox, VTK and OpenVDB (wall, RSS).
#                armadillo_s4.ply (250 MB) is made in build/bench/, not in
#                data/meshes, so that the tests that read every mesh there
#                do not load it
#   --peer-timeout S  a peer case running over S seconds is killed and
#                reported as skipped (default: none; --big: 300)
#   --peers      also time VTK and OpenVDB on the same cases in the same run
#                (scripts/bench/bench_peers.py; needs scripts/setup.sh --peers)
#   --repeat R   runs per case; the run with the best process time is shown, peak
#                RSS is the largest of the runs (default 3; peers: 1 unless
#                --repeat is given)
#   --method M   ray, tetra or all (default all: ray, plus tetra when
#                `clvox --help` offers it)
#
# Cases: armadillo.off (52 k triangles) at N = 128, 256, 512, 1024;
# armadillo subdivided twice (832 k) and three times (3.3 M triangles, binary
# PLY, made by scripts/bench/subdivide.c) at 512; bunny00 (75 k) and cow (5.8 k) at
# 256, 512, 1024.
# Meshes come from scripts/fetch_meshes.sh. The PoCL kernel cache
# (POCL_CACHE_DIR, default build/pocl-cache) is warmed by one run first.
# Stage seconds are those of clvox's summary ("time" line); "process" is the
# wall time of the whole clvox process, peak RSS its maximum resident set
# (/usr/bin/time -v). The output file is written (RLE, the default)
# to build/bench/ and deleted after its size is taken.
# Writes a markdown report to stdout and to build/bench/results.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

quick=0 big=0 peers=0 repeat=3 peer_repeat=1 methods=all peer_timeout=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --big) big=1 ;;
    --peer-timeout) peer_timeout=${2:?--peer-timeout needs seconds}; shift ;;
    --peers) peers=1 ;;
    --repeat) repeat=${2:?--repeat needs a number}; peer_repeat=$repeat; shift ;;
    --repeat=*) repeat=${1#*=}; peer_repeat=$repeat ;;
    --method) methods=${2:?--method needs ray, tetra or all}; shift ;;
    --method=*) methods=${1#*=} ;;
    -h|--help) sed -n '2,36p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
case "$repeat" in ''|*[!0-9]*|0) echo "bench.sh: --repeat needs a positive number" >&2; exit 2 ;; esac

clvox=${CLVOX_BENCH_BIN:-build/release/clvox}   # override to time another build
outdir=build/bench
tools=build/release/bench   # make bench-tools
mkdir -p "$outdir" "$tools"
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
log() { echo "bench: $*" >&2; }

if [ ! -x /usr/bin/time ]; then
  echo "bench.sh: /usr/bin/time is missing (Debian package 'time'; scripts/setup.sh installs it)" >&2; exit 1
fi
if [ ! -x "$clvox" ]; then
  log "building clvox (make CONFIG=release)"
  make -s CONFIG=release >&2 || { echo "bench.sh: build failed" >&2; exit 1; }
fi
[ -f data/meshes/armadillo.off ] || sh scripts/fetch_meshes.sh >&2

# Large meshes: armadillo subdivided 2 and 3 times.
if [ "$quick" -eq 0 ]; then
  make -s CONFIG=release bench-tools >&2
  for k in 2 3; do
    [ -f "data/meshes/armadillo_s$k.ply" ] || "$tools/subdivide" data/meshes/armadillo.off "$k" "data/meshes/armadillo_s$k.ply" >&2
  done
  if [ "$big" -eq 1 ] && [ ! -f "$outdir/armadillo_s4.ply" ]; then
    "$tools/subdivide" data/meshes/armadillo.off 4 "$outdir/armadillo_s4.ply" >&2
  fi
fi
# A case's mesh: data/meshes, else build/bench (the 13.3 M one).
mesh_path() { if [ -f "data/meshes/$1" ] || [ ! -f "$outdir/$1" ]; then echo "data/meshes/$1"; else echo "$outdir/$1"; fi; }

insides="default"
if [ "$quick" -eq 1 ]; then
  cases="armadillo.off:128 armadillo.off:256 cow.off:256"
elif [ "$big" -eq 1 ]; then
  cases="armadillo.off:512 armadillo.off:1024 armadillo_s2.ply:512 armadillo_s2.ply:1024
         armadillo_s3.ply:512 armadillo_s3.ply:1024 armadillo_s4.ply:512 armadillo_s4.ply:1024"
  insides="default parity"
  [ "$methods" = all ] && methods=ray
  [ -n "$peer_timeout" ] || peer_timeout=300
else
  cases="armadillo.off:128 armadillo.off:256 armadillo.off:512 armadillo.off:1024
         armadillo_s2.ply:512 armadillo_s3.ply:512
         bunny00.off:256 bunny00.off:512 bunny00.off:1024 cow.off:256 cow.off:512 cow.off:1024"
fi
cases=${CLVOX_BENCH_CASES:-$cases}   # override, e.g. "cow.off:64" to try the script
help=$("$clvox" --help 2>&1 || true)
case "$methods" in
  all) mlist="ray"; if grep -q -- 'tetra' <<<"$help"; then mlist="ray tetra"; fi ;;
  ray|tetra) mlist=$methods ;;
  *) echo "bench.sh: --method must be ray, tetra or all" >&2; exit 2 ;;
esac

tmp=$(mktemp -d "$outdir/run.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

# One clvox run under /usr/bin/time; prints one tab-separated record:
# triangles grid load setup partition cast classify write total process rss_mb out_mb filled
run_one() {
  local mesh=$1 n=$2 method=$3 inside=${4:-default} out="$tmp/out.exr" rc=0 t0 t1
  local extra=()
  [ "$inside" = default ] || extra=(--inside "$inside")
  rm -f "$out"
  t0=$EPOCHREALTIME
  /usr/bin/time -v -o "$tmp/time.txt" "$clvox" "$mesh" -o "$out" -r "$n" --method "$method" "${extra[@]}" --no-progress \
    >"$tmp/stdout.txt" 2>"$tmp/stderr.txt" || rc=$?
  t1=$EPOCHREALTIME
  if [ "$rc" -ne 0 ]; then
    log "FAILED (exit $rc): $clvox $mesh -r $n --method $method ${extra[*]}"
    sed 's/^/    /' "$tmp/stderr.txt" | tail -n 5 >&2
    return 1
  fi
  local bytes=0
  [ -f "$out" ] && bytes=$(stat -c %s "$out")
  rm -f "$out"
  awk -v bytes="$bytes" -v timefile="$tmp/time.txt" -v t0="$t0" -v t1="$t1" '
    function grab(name,   i) { for (i = 1; i < NF; i++) if ($i == name && $(i+1) ~ /^[0-9.]+$/) return $(i+1); return "" }
    /^time[ \t]/ || / partition [0-9.]+ / {
      for (k in want) { v = grab(k); if (v != "") t[k] = v } }
    /^grid[ \t]/ { if (match($0, /[0-9]+ x [0-9]+ x [0-9]+/)) { g = substr($0, RSTART, RLENGTH); gsub(/ /, "", g) } }
    /[0-9]+ triangles/ && tri == "" { if (match($0, /[0-9]+ triangles/)) tri = substr($0, RSTART, RLENGTH - 10) }
    /^filled[ \t]/ { filled = $2 }
    BEGIN { split("load setup partition cast classify write total", w, " "); for (i in w) want[w[i]] = 1 }
    END {
      while ((getline line < timefile) > 0) {
        if (line ~ /Maximum resident set size/) { sub(/.*: */, "", line); rss = line / 1024 }
        if (line ~ /(User|System) time \(seconds\)/) { sub(/.*: */, "", line); cpu += line }
      }
      printf "%s\t%s", (tri == "" ? "?" : tri), (g == "" ? "?" : g)
      split("load setup partition cast classify write total", w, " ")
      for (i = 1; i <= 7; i++) printf "\t%s", ((w[i] in t) ? t[w[i]] : "-")
      printf "\t%.3f\t%.0f\t%.1f\t%s\t%.2f\n", t1 - t0, rss, bytes / 1e6, (filled == "" ? "?" : filled), cpu
    }' "$tmp/stdout.txt"
}

# Warm the PoCL kernel cache (and the page cache for the meshes).
# A method whose warm-up fails (e.g. "not available in this build") is dropped.
ok=""
device=""
for m in $mlist; do
  if run_one data/meshes/armadillo.off 64 "$m" >/dev/null; then
    ok="$ok $m"
    [ -n "$device" ] || device=$(sed -n 's/^device[ \t]*//p' "$tmp/stdout.txt" | head -n 1)
  else
    log "dropping method $m"
  fi
done
mlist=$ok
[ -n "$mlist" ] || { echo "bench.sh: warm-up runs failed" >&2; exit 1; }

load_before=$(cut -d ' ' -f 1-3 /proc/loadavg)
results="$tmp/results.tsv"
: >"$results"
for c in $cases; do
  mesh=${c%%:*} n=${c##*:}
  path=$(mesh_path "$mesh")
  [ -f "$path" ] || { log "skipping $mesh (missing)"; continue; }
  for m0 in $mlist; do
   for ins in $insides; do
    m=$m0
    [ "$ins" = default ] || m="$m0/$ins"
    best="" maxrss=0
    for ((r = 0; r < repeat; r++)); do
      rec=$(run_one "$path" "$n" "$m0" "$ins") || { best=""; break; }
      total=$(cut -f 10 <<<"$rec"); rss=$(cut -f 11 <<<"$rec")
      [ "${rss%.*}" -gt "$maxrss" ] && maxrss=${rss%.*}
      if [ -z "$best" ] || awk -v a="$total" -v b="$(cut -f 10 <<<"$best")" 'BEGIN { exit !(a < b) }'; then best=$rec; fi
    done
    if [ -n "$best" ]; then
      best=$(awk -F '\t' -v OFS='\t' -v rss="$maxrss" '{ $11 = rss; print }' <<<"$best")
      printf '%s\t%s\t%s\t%s\n' "$mesh" "$n" "$m" "$best" >>"$results"
      log "$(printf '%-18s N=%-5s %-5s process %ss, %s MB' "$mesh" "$n" "$m" "$(cut -f 10 <<<"$best")" "$maxrss")"
    else
      printf '%s\t%s\t%s\tFAILED\n' "$mesh" "$n" "$m" >>"$results"
    fi
   done
  done
done

report="$outdir/results.md"
{
  cpu=$(sed -n 's/^model name[ \t]*: //p' /proc/cpuinfo | head -n 1)
  echo "# clvox benchmark"
  echo
  echo "$(date -u '+%Y-%m-%d %H:%M UTC'), clvox $("$clvox" --version 2>/dev/null | head -n 1 | awk '{ print $2 }')" \
       "(git $(git rev-parse --short HEAD 2>/dev/null || echo '?')), $(nproc) cores ($cpu), device: ${device:-?}," \
       "best of $repeat run(s), PoCL kernel cache warm."
  echo
  echo "Load average before / after: $load_before / $(cut -d ' ' -f 1-3 /proc/loadavg) (other work on the"
  echo "machine makes the times noisy)."
  echo
  echo "Stage seconds from clvox's summary (\`time\` line): load = reading and validating the mesh,"
  echo "setup = OpenCL context + kernels (from PoCL's cache), total = the clvox_voxelize call"
  echo "(partition + cast + classify + write; stages overlap when slabs are streamed)."
  echo "process = wall time of the whole clvox process (start to exit, output written and"
  echo "closed); CPU s = its user + system time (all threads); peak RSS from /usr/bin/time -v."
  echo "The run with the best process time is shown."
  echo
  echo "| mesh | triangles | N | grid | method | load | setup | partition | cast | classify | write | total | process | CPU s | peak RSS MB | output MB | filled voxels |"
  echo "|---|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  awk -F '\t' '$4 == "FAILED" { printf "| %s | | %s | | %s | failed ||||||||||||\n", $1, $2, $3; next }
    { printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n",
        $1, $4, $2, $5, $3, $6, $7, $8, $9, $10, $11, $12, $13, $17, $14, $15, $16 }' "$results"
  echo
  echo "Growth with N (armadillo.off, 52 k triangles): time(2N) / time(N); a stage that"
  echo "scales with the voxel count grows 8x, with the ray count (N^2) 4x."
  echo
  echo "| method | N -> 2N | load | partition | cast | classify | write | total | process | peak RSS |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
  awk -F '\t' '
    function r(a, b) { return (a + 0 > 0 && b != "-" && a != "-") ? sprintf("%.2f", b / a) : "-" }
    $1 == "armadillo.off" && $4 != "FAILED" { row[$3, $2] = $0; seen[$3] = 1 }
    END {
      for (m in seen) for (n = 128; n < 1024; n *= 2) {
        if (!(((m, n) in row) && ((m, 2 * n) in row))) continue
        split(row[m, n], a, "\t"); split(row[m, 2 * n], b, "\t")
        printf "| %s | %d -> %d | %s | %s | %s | %s | %s | %s | %s | %s |\n", m, n, 2 * n,
          r(a[6], b[6]), r(a[8], b[8]), r(a[9], b[9]), r(a[10], b[10]), r(a[11], b[11]), r(a[12], b[12]),
          r(a[13], b[13]), r(a[14], b[14])
      }
    }' "$results" | sort
  echo
  echo "Growth with triangle count at N = 512 (armadillo, subdivided x4 per step): ratio to the"
  echo "52 k-triangle armadillo."
  echo
  echo "| method | mesh | triangles | x triangles | load | partition | cast | classify | write | total | process | peak RSS |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  awk -F '\t' '
    function r(a, b) { return (a + 0 > 0 && b != "-" && a != "-") ? sprintf("%.2f", b / a) : "-" }
    $2 == 512 && $4 != "FAILED" && $1 ~ /^armadillo/ { row[$3, $1] = $0; seen[$3] = 1 }
    END {
      for (m in seen) {
        if (!((m, "armadillo.off") in row)) continue
        split(row[m, "armadillo.off"], a, "\t")
        n = split("armadillo_s2.ply armadillo_s3.ply", ms, " ")
        for (i = 1; i <= n; i++) {
          if (!((m, ms[i]) in row)) continue
          split(row[m, ms[i]], b, "\t")
          printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", m, ms[i], b[4], r(a[4], b[4]),
            r(a[6], b[6]), r(a[8], b[8]), r(a[9], b[9]), r(a[10], b[10]), r(a[11], b[11]), r(a[12], b[12]),
            r(a[13], b[13]), r(a[14], b[14])
        }
      }
    }' "$results" | sort
  echo
  echo "Where the time goes (share of the process wall time; streamed stages overlap, so the"
  echo "shares may add up to more than 100 %; other = process - load - setup - total):"
  echo
  echo "| mesh | N | method | load | setup | partition | cast | classify | write | other |"
  echo "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"
  awk -F '\t' '
    function p(x) { return (x == "-" || $13 + 0 <= 0) ? "-" : sprintf("%.0f %%", 100 * x / $13) }
    $4 != "FAILED" { printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $3, p($6), p($7), p($8), p($9),
      p($10), p($11), p($13 - $6 - $7 - $12) }' "$results"
  echo
  echo "Ray vs tetra: the same cases side by side, ratio = tetra / ray (below 1: tetra is"
  echo "faster). total = the clvox_voxelize call, process = the whole clvox process."
  echo
  echo "| mesh | triangles | N | ray total | tetra total | ratio | ray process | tetra process | ratio | same voxels |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  awk -F '\t' '
    $4 != "FAILED" { row[$1, $2, $3] = $0; if (!(($1, $2) in seen)) { seen[$1, $2] = 1; order[++n] = $1 SUBSEP $2 } }
    function q(a, b) { return (a + 0 > 0) ? sprintf("%.2f", b / a) : "-" }
    END {
      for (i = 1; i <= n; i++) {
        split(order[i], k, SUBSEP)
        if (!(((k[1], k[2], "ray") in row) && ((k[1], k[2], "tetra") in row))) continue
        split(row[k[1], k[2], "ray"], a, "\t"); split(row[k[1], k[2], "tetra"], b, "\t")
        printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", k[1], a[4], k[2], a[12], b[12], q(a[12], b[12]),
          a[13], b[13], q(a[13], b[13]), (a[16] == b[16] ? "yes" : "NO")
      }
    }' "$results"
  echo
  echo "Targets (issue 2; whole process, kernel cache warm, best method per case):"
  echo
  echo "| case | target | measured | met |"
  echo "|---|---|---|---|"
  awk -F '\t' '
    $4 != "FAILED" { k = $1 ":" $2; if (!(k in best) || $13 + 0 < best[k] + 0) { best[k] = $13; rss[k] = $14; how[k] = $3 } }
    function t(k, label, secs, mb,   ok, m) {
      if (!(k in best)) return
      ok = (best[k] + 0 <= secs) && (mb == 0 || rss[k] + 0 <= mb)
      m = sprintf("%.2f s (%s)", best[k], how[k]); if (mb) m = m sprintf(", %d MB", rss[k])
      printf "| %s | <= %s s%s | %s | %s |\n", label, secs, (mb ? sprintf(", <= %d MB", mb) : ""), m, (ok ? "yes" : "NO")
    }
    END {
      t("armadillo.off:512", "armadillo 52 k, 512^3", 0.7, 0)
      t("armadillo_s2.ply:512", "armadillo 832 k, 512^3", 1.5, 0)
      t("armadillo_s3.ply:512", "armadillo 3.3 M (binary PLY), 512^3", 4, 0)
      t("armadillo.off:1024", "armadillo 52 k, 1024^3", 3, 300)
    }' "$results"
  echo
  echo "Targets (issue 3, tetra method): meshes up to 100 k triangles at 512^3 within 2x of"
  echo "the ray method (both the clvox_voxelize time and the whole process are shown), and"
  echo "bunny00 at 512^3 in <= 2 s end to end."
  echo
  echo "| case | target | measured | met |"
  echo "|---|---|---|---|"
  awk -F '\t' '
    $4 != "FAILED" { row[$1, $2, $3] = $0; if ($2 == 512 && $4 + 0 <= 100000 && !($1 in seen)) { seen[$1] = 1; order[++n] = $1 } }
    END {
      for (i = 1; i <= n; i++) {
        m = order[i]
        if (!(((m, 512, "ray") in row) && ((m, 512, "tetra") in row))) continue
        split(row[m, 512, "ray"], a, "\t"); split(row[m, 512, "tetra"], b, "\t")
        rt = b[12] / a[12]; rp = b[13] / a[13]
        printf "| %s (%s tris), 512^3, tetra / ray | <= 2 | %.2f (voxelize), %.2f (process) | %s |\n", m, a[4], rt, rp,
          (rt <= 2 && rp <= 2) ? "yes" : ((rp <= 2) ? "process only" : "NO")
      }
      if (("bunny00.off", 512, "tetra") in row) {
        split(row["bunny00.off", 512, "tetra"], b, "\t")
        printf "| bunny00.off, 512^3, tetra, whole process | <= 2 s | %.2f s | %s |\n", b[13], (b[13] <= 2 ? "yes" : "NO")
      }
    }' "$results"
} >"$report"

if [ "$peers" -eq 1 ]; then
  pcases=""
  for c in $cases; do pcases="$pcases $(mesh_path "${c%%:*}"):${c##*:}"; done
  ptsv="$tmp/peers.tsv"
  : >"$ptsv"
  popts=(--repeat "$peer_repeat" --tsv "$ptsv")
  [ -z "$peer_timeout" ] || popts+=(--timeout "$peer_timeout")
  log "running the peers (VTK, OpenVDB)"
  {
    echo
    echo "## Peers (same meshes and grids; scripts/bench/bench_peers.py, best of $peer_repeat)"
    echo
    echo "In-process seconds from the mesh file to a dense occupancy array in memory (no file"
    echo "written); peak RSS of a fresh Python process per case. VTK: vtkPolyDataToImageStencil,"
    echo "1 thread; OpenVDB: meshToVolume (level set, TBB threads on all cores) + dense copy."
    echo
    /usr/bin/python3 scripts/bench/bench_peers.py "${popts[@]}" $pcases
  } >>"$report"
  if [ "$big" -eq 1 ]; then
    {
      echo
      echo "## Big meshes: clvox, VTK and OpenVDB in the same run (wall s / peak RSS MB)"
      echo
      echo "clvox: the whole process (best of $repeat; RSS the largest), writing the EXR; default = the"
      echo "winding-number inside test, parity = --inside parity (even-odd, as VTK's stencil)."
      echo "Peers: in-process seconds from the mesh file to a dense array (best of $peer_repeat), peak RSS"
      echo "of the Python process${peer_timeout:+; cases over $peer_timeout s were killed and are marked skipped}."
      echo
      echo "| mesh | triangles | N | clvox default | clvox parity | VTK | OpenVDB |"
      echo "|---|---:|---:|---:|---:|---:|---:|"
      awk -F '\t' '
        FNR == NR { if ($4 != "FAILED") { c[$1, $2, $3] = sprintf("%.2f / %d", $13, $14); tri[$1] = $4 }
                    else c[$1, $2, $3] = "failed"
                    if (!(($1, $2) in seen)) { seen[$1, $2] = 1; order[++n] = $1 SUBSEP $2 }; next }
        { p[$1, $2, $4] = ($6 ~ /^[0-9.]+$/) ? sprintf("%.2f / %d", $6, $8) : $6 }
        function g(a, k) { return (k in a) ? a[k] : "-" }
        END {
          for (i = 1; i <= n; i++) {
            split(order[i], k, SUBSEP)
            printf "| %s | %s | %s | %s | %s | %s | %s |\n", k[1], g(tri, k[1]), k[2], g(c, k[1] SUBSEP k[2] SUBSEP "ray"),
              g(c, k[1] SUBSEP k[2] SUBSEP "ray/parity"), g(p, "vtk" SUBSEP k[1] SUBSEP k[2]),
              g(p, "openvdb" SUBSEP k[1] SUBSEP k[2])
          }
        }' "$results" "$ptsv"
    } >>"$report"
  fi
fi
cat "$report"
log "report written to $outdir/results.md"
