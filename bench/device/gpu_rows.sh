#!/usr/bin/env bash
# Every open issue's GPU rows in three calls on one warm GPU machine (its 30 s idle window
# between them), from the project root, after ../shared/gpu/kit.sh --peers and a baseline
# binary, both recompressed (xz: .gpu/bin/hooke.xz, .gpu/old/hooke.xz). Build the baseline in
# its own target folder seeded from ours (a target shared between two checkouts can keep a stale
# binary: cargo compares file times, and the older checkout's files look up to date):
#   git worktree add /tmp/old 0fbce83 && cp -a target /tmp/bt && (cd /tmp/old &&
#     CARGO_TARGET_DIR=/tmp/bt cargo build --release --locked -q) && mkdir -p .gpu/old &&
#     strip -o /tmp/hooke-old /tmp/bt/release/hooke && xz -6 -c /tmp/hooke-old >.gpu/old/hooke.xz
#   ../shared/gpu/kit.sh --peers && gunzip -c .gpu/bin/hooke.gz | xz -6 >.gpu/bin/hooke.xz &&
#     rm .gpu/bin/hooke.gz
#   1. carrying [".gpu/bin", ".gpu/gl", ".gpu/old", ".gpu/w1"]:  bash bench/device/gpu_rows.sh a
#      (or, for the peers alone, carrying [".gpu/bin", ".gpu/gl", ".gpu/w1"]: gpu_rows.sh w, then
#      [".gpu/w2"]: w, then [".gpu/w3", ".gpu/p"]: c)
#   2. carrying [".gpu/w2"]:                                       bash bench/device/gpu_rows.sh b
#   3. carrying [".gpu/w3"]:                                       bash bench/device/gpu_rows.sh c
# a: issue 29's rows, this binary against the baseline (round 1), issue 31's rows at 1/60 s;
# b: issue 29's round 2, issue 27's recordings, issue 31's thread scaling;
# c: the peers (Warp with CUDA graphs, Taichi CUDA) and this binary on the peer cloth, 2 rounds;
# s (alone, carrying [".gpu/bin", ".gpu/gl", ".gpu/old", ".gpu/p"]): the small scenes, this
#   binary against the baseline, three rounds interleaved (the one-workgroup steps' sizes).
# Each phase appends JSON lines to $OUT/<phase>.jsonl and prints its tables.
set -u
phase=${1:?phase a, b or c}
out=${OUT:-/tmp}
mkdir -p /tmp/parts
# A call's ignored folders that it does not carry are gone there, /tmp stays: Warp's parts
# gather in /tmp/parts, the binaries in /tmp, and .gpu/p (env.sh and the peers' scripts, small)
# travels with every call after the first.
for w in .gpu/w1 .gpu/w2; do [ -d $w ] && cp $w/* /tmp/parts/; done
G=.gpu/bin
[ -f $G/env.sh ] || G=.gpu/p
# The binaries travel xz-compressed (14 MB each, against 22 gzipped) so that both fit in one
# call beside Warp's first part.
# A binary that travels replaces the one a warm machine kept.
[ -f .gpu/bin/hooke.xz ] && xz -dc .gpu/bin/hooke.xz >/tmp/hooke && chmod +x /tmp/hooke
# The Vulkan loader is installed by the call that carries .gpu/gl (w's first call too: phase c
# carries no .gpu/gl, and its Hooke rows found no loader when w skipped this).
[ -f $G/env.sh ] && . $G/env.sh
[ "$phase" = w ] && { ls -la /tmp/parts; exit 0; }
J="--json --repeat 3"
rows=$out/$phase.jsonl
: >"$rows"
# One JSON line of `bench throughput`, labelled.
row() {
  local label=$1 bin=$2 line
  shift 2
  line=$(timeout 120 "$bin" bench throughput "$@" $J 2>/dev/null | head -1)
  [ -n "$line" ] && echo "{\"label\":\"$label\",\"args\":\"$*\",\"result\":$line}" >>"$rows"
}
# Issue 29: the baseline ("old") against this binary ("new"), one round.
issue29() {
  local old=/tmp/hooke-old
  [ -x $old ] || { xz -dc .gpu/old/hooke.xz >$old && chmod +x $old; }
  for tag in old new; do
    local b=$old
    [ $tag = new ] && b=$H
    row "29-$tag" $b hair --steps 40000 --batch 2000
    row "29-$tag" $b jello --steps 40000 --batch 2000
    row "29-$tag" $b cloth --steps 20000 --batch 2000
    row "29-$tag" $b cloth-64 --steps 20000 --batch 1000
    row "29-$tag" $b cloth-256 --steps 5000 --batch 1000
    row "29-$tag" $b cloth-1024 --steps 1000 --batch 500
    row "29-$tag" $b bench/scenes/warp-cloth-64.toml --steps 960 --batch 16
    row "29-$tag" $b examples/scenes/cloth-fold.toml --steps 6000 --batch 1000
    row "29-$tag" $b jello --integrator xpbd --steps 20000 --batch 2000
  done
}
# The peer cloth at 1/60 s (a step per frame), and its fine-step reference (dt = 1e-4).
peer60() {
  local n=$1 p=$G/peers
  sed 's/^frame_rate_hz = .*/frame_rate_hz = 60/; s/^substeps = .*/substeps = 1/' \
    $p/peer-cloth-$n.toml >/tmp/peer-cloth-$n-60hz.toml
  # 2 s = 120 steps: one warm-up step and 119 timed.
  J="--json --repeat 1" row "31-peer60" $H /tmp/peer-cloth-$n-60hz.toml --integrator implicit \
    --steps 119 --batch 1
  J="--json --repeat 1" row "31-peer60" $H /tmp/peer-cloth-$n-60hz.toml --integrator vbd \
    --steps 119 --batch 1
  J="--json --repeat 1" row "31-peer60" $H /tmp/peer-cloth-$n-60hz.toml --integrator bdf2 \
    --steps 119 --batch 1
  # 2 s at dt = 1e-4: 1 000 warm-up steps and 19 000 timed.
  timeout 120 "$H" bench throughput $p/peer-cloth-$n.toml --steps 19000 --batch 1000 --repeat 1 \
    --json 2>/dev/null | head -1 | sed "s/^/{\"label\":\"31-ref\",\"result\":/; s/\$/}/" >>"$rows"
}
# Phases v, t and x: the kit pack.sh made (.gpu/t/kit.tar.xz: this hooke, the baseline's as
# hooke-old, an earlier one as hooke-v1 where packed, the GPU test binaries), unpacked where the
# test binaries look: the checkout they were built in (/work/main) and target/release/hooke there.
# `left S` says whether fewer than S seconds have passed since.
open_kit() {
  t0=$(date +%s)
  mkdir -p /tmp/t && xz -dc .gpu/t/kit.tar.xz | tar xf - -C /tmp/t
  # install, not cp: env.sh, sourced above, left an empty /tmp/hooke without a hooke.gz.
  for b in /tmp/t/hooke*; do install -m 755 "$b" "/tmp/$(basename "$b")"; done
  H=/tmp/hooke
  nvidia-smi -L
  [ "$PWD" = /work/main ] || { mkdir -p /work && ln -sfn "$PWD" /work/main; }
  mkdir -p target/release && cp /tmp/hooke target/release/hooke
  export HOOKE_CACHE_DIR=/tmp/hooke-cache HOOKE_REQUIRE_ADAPTER=1
}
left() { [ $(($(date +%s) - t0)) -lt "$1" ]; }
# The test binaries named, as `cargo test --release` would run them, until 330 s have passed.
# TEST_ARGS="--test-threads 1": the H200's hang of 2026-11-28 (BENCHMARKS.md) came with 16.
run_tests() {
  for b in "$@"; do
    left 330 || { echo "skipped $b: out of time" | tee -a $out/tests.txt; continue; }
    echo "== $b" >>$out/tests.txt
    timeout 120 /tmp/t/tests/$b ${TEST_ARGS:-} >>$out/tests.txt 2>&1
    echo "$b: exit $? $(grep -E '^test result' $out/tests.txt | tail -1)"
  done
  grep -E "FAILED|panicked" -A2 $out/tests.txt | head -40
}
case $phase in
x)
  # (x: not w, which the peers take above.) The second call of 2026-11-28 (an H200), carrying
  # [".gpu/gl", ".gpu/p", ".gpu/t"]: issue 46's
  # VBD rows for the baseline (hooke-old), the first call's binary (hooke-v1) and this one, then
  # the implicit families' probe and the GPU test binaries, most telling first, until 330 s.
  open_kit
  for tag in old v1 new; do
    b=/tmp/hooke-$tag
    [ $tag = new ] && b=$H
    row "46-$tag" $b bench/scenes/jello-60hz.toml --integrator vbd --steps 600 --batch 60
    row "46-$tag" $b bench/scenes/cloth-60hz.toml --integrator vbd --steps 600 --batch 60
    row "46-$tag" $b bench/scenes/cloth-256-60hz.toml --integrator implicit --steps 60 --batch 1
  done
  python3 bench/device/summarize.py "$rows"
  for i in implicit bdf2; do
    timeout 60 "$H" check cloth --integrator $i --verify 2>&1 | grep -E "^conformance"
  done | tee $out/verify.txt
  run_tests hard_cases gpu_implicit effects self_collision vbd gpu energy gpu_fused xpbd hard_limits
  exit 0
  ;;
v | t)
  # (t: the test binaries alone, as pack.sh's TESTS name them.)
  # Real-driver conformance (issue 49) and the cost of waiting between submissions (issue 46)
  # in one call, carrying [".gpu/gl", ".gpu/p", ".gpu/t"]. .gpu/p holds env.sh and the peers'
  # files (../shared/gpu/), .gpu/t/kit.tar.xz this hooke, the baseline (hooke-old) and the GPU
  # test binaries, stripped, in one xz stream whose window spans them all (they share most of
  # their code: ten binaries and two hookes in about 10 MB):
  #   bench/device/pack.sh 77e1e67
  open_kit
  # The conformance probe for every integrator's kernel families, as `check` prints it.
  verify_all() {
    for i in semi-implicit euler rk2 rk4 verlet implicit bdf2 xpbd vbd; do
      timeout 60 "$H" check cloth --integrator $i --verify 2>&1 | grep -E "^adapter|^conformance"
    done | tee $out/verify.txt
    timeout 60 "$H" check jello --integrator implicit --verify 2>&1 | grep -E "^conformance" |
      tee -a $out/verify.txt
  }
  [ "$phase" = t ] || { verify_all; }
  # The GPU test binaries on this driver.
  run_tests $(ls /tmp/t/tests)
  # Submissions that wait for the one before (issue 46) against the baseline, interleaved.
  [ "$phase" = t ] && exit 0
  for r in 1 2; do for tag in old new; do
    left 470 || break 2
    b=/tmp/hooke-old
    [ $tag = new ] && b=$H
    row "46-$tag" $b hair --steps 40000 --batch 2000
    row "46-$tag" $b jello --steps 40000 --batch 2000
    row "46-$tag" $b cloth-1024 --steps 1000 --batch 500
    row "46-$tag" $b bench/scenes/jello-60hz.toml --integrator vbd --steps 600 --batch 60
    row "46-$tag" $b bench/scenes/cloth-60hz.toml --integrator vbd --steps 600 --batch 60
    row "46-$tag" $b bench/scenes/cloth-256-60hz.toml --integrator implicit --steps 60 --batch 1
  done; done
  ;;
one)
  # Every issue's rows that need no peer, this binary alone, in one short call (carrying
  # [".gpu/bin", ".gpu/gl", ".gpu/p"]): for a card lent only for a few minutes.
  nvidia-smi -L
  "$H" check cloth-1024 | grep -E "adapter"
  row one $H hair --steps 40000 --batch 2000
  row one $H jello --steps 40000 --batch 2000
  row one $H cloth --steps 20000 --batch 2000
  row one $H cloth-64 --steps 20000 --batch 1000
  row one $H cloth-256 --steps 5000 --batch 1000
  row one $H cloth-1024 --steps 1000 --batch 500
  row one $H examples/scenes/cloth-fold.toml --steps 6000 --batch 1000
  row one $H bench/scenes/jello-60hz.toml --integrator implicit --steps 120 --batch 1
  row one $H bench/scenes/jello-60hz.toml --integrator vbd --steps 600 --batch 60
  row one $H bench/scenes/cloth-256-60hz.toml --integrator implicit --steps 60 --batch 1
  peer60 64
  /usr/bin/time -f "run cloth-256 --duration 10 --save: %e s wall, %M KB peak" \
    timeout 60 "$H" run cloth-256 --duration 10 --save /tmp/c256.rrd 2>&1 | tail -2
  # What a dispatch costs apart from its work (examples/dispatch_floor.rs), where it travels:
  #   strip -o /tmp/df target/release/examples/dispatch_floor && mkdir -p .gpu/ex &&
  #   xz -6 -c /tmp/df >.gpu/ex/dispatch_floor.xz       (and carry ".gpu/ex")
  if [ -f .gpu/ex/dispatch_floor.xz ]; then
    xz -dc .gpu/ex/dispatch_floor.xz >/tmp/dispatch_floor && chmod +x /tmp/dispatch_floor
    for w in 64 4096 65536; do timeout 60 /tmp/dispatch_floor 2000 $w; done
  fi
  ;;
l)
  # Large steps (issue 31): implicit Euler's one-workgroup step at several thread counts and
  # VBD's sweeps in one workgroup against a dispatch per colour (examples/large_steps.rs), then
  # the one-step-per-frame rows, this binary against the baseline. Carrying [".gpu/bin",
  # ".gpu/gl", ".gpu/old", ".gpu/ex", ".gpu/p"], .gpu/ex holding large_steps.xz:
  #   strip -o /tmp/ls target/release/examples/large_steps && xz -6 -c /tmp/ls >.gpu/ex/large_steps.xz
  nvidia-smi -L
  old=/tmp/hooke-old
  [ -x $old ] || { xz -dc .gpu/old/hooke.xz >$old && chmod +x $old; }
  xz -dc .gpu/ex/large_steps.xz >/tmp/large_steps && chmod +x /tmp/large_steps
  L=/tmp/large_steps
  f=0.016666666666666666
  timeout 120 $L bench/scenes/jello-60hz.toml $f 60 3 ${JELLO_THREADS:-64,128,256,512,1024}
  timeout 60 $L bench/scenes/cloth-60hz.toml $f 60 3 ${CLOTH_THREADS:-64,256,1024}
  timeout 60 $L bench/scenes/hair-60hz.toml $f 240 3 64,128
  sed 's/^frame_rate_hz = .*/frame_rate_hz = 60/; s/^substeps = .*/substeps = 1/' \
    $G/peers/peer-cloth-64.toml >/tmp/peer-cloth-64-60hz.toml
  timeout 60 $L /tmp/peer-cloth-64-60hz.toml $f 60 3
  for tag in old new; do
    b=$old
    [ $tag = new ] && b=$H
    row "31-$tag" $b bench/scenes/jello-60hz.toml --integrator implicit --steps 120 --batch 1
    row "31-$tag" $b bench/scenes/jello-60hz.toml --integrator vbd --steps 600 --batch 60
    row "31-$tag" $b bench/scenes/cloth-60hz.toml --integrator implicit --steps 120 --batch 1
    row "31-$tag" $b bench/scenes/cloth-60hz.toml --integrator vbd --steps 600 --batch 60
    row "31-$tag" $b bench/scenes/cloth-256-60hz.toml --integrator implicit --steps 60 --batch 1
    row "31-$tag" $b bench/scenes/hair-60hz.toml --integrator implicit --steps 600 --batch 1
    row "31-$tag" $b bench/scenes/hair-60hz.toml --integrator vbd --steps 600 --batch 60
  done
  # BDF2 (this binary only: the baseline has none).
  for s in jello cloth hair; do
    row "31-bdf2" $H bench/scenes/$s-60hz.toml --integrator bdf2 --steps 120 --batch 1
  done
  row "31-bdf2" $H bench/scenes/cloth-256-60hz.toml --integrator bdf2 --steps 60 --batch 1
  peer60 64
  peer60 256
  if [ -f .gpu/ex/dispatch_floor.xz ]; then
    xz -dc .gpu/ex/dispatch_floor.xz >/tmp/dispatch_floor && chmod +x /tmp/dispatch_floor
    for w in 64 4096 65536; do timeout 60 /tmp/dispatch_floor 2000 $w; done
  fi
  ;;
mg)
  # Multigrid on the GPU (issue 31), one short call carrying [".gpu/bin",
  # ".gpu/gl", ".gpu/old", ".gpu/ex", ".gpu/p"], .gpu/ex holding preconditioners.xz:
  #   strip -o /tmp/pc target/release/examples/preconditioners && mkdir -p .gpu/ex &&
  #     xz -6 -c /tmp/pc >.gpu/ex/preconditioners.xz
  # cloth-256 and the peer cloth at one step per frame, this binary (multigrid from 4 096
  # masses) against the baseline (block Jacobi on the GPU), then each preconditioner in one
  # process on the GPU's per-pass path.
  nvidia-smi -L
  old=/tmp/hooke-old
  [ -x $old ] || { xz -dc .gpu/old/hooke.xz >$old && chmod +x $old; }
  for tag in old new; do
    b=$old
    [ $tag = new ] && b=$H
    row "31-$tag" $b bench/scenes/cloth-256-60hz.toml --integrator implicit --steps 60 --batch 1
    row "31-$tag" $b bench/scenes/cloth-256-60hz.toml --integrator bdf2 --steps 60 --batch 1
  done
  peer60 64
  peer60 256
  # The preconditioner's crossing in stiffness against the step (MULTIGRID_MIN_STIFFNESS, set
  # from two CPU cores): cloth-256 at 4 and 16 steps a frame ((h² Σk + h Σc) / m 1 138 and 76)
  # with each preconditioner on the GPU, and at its own step (0.6, block Jacobi by default now).
  for s in 4 16; do
    sed "s/substeps = 1/substeps = $s/; 0,/^name = .*/s//name = \"cloth-256-s$s\"/" \
      bench/scenes/cloth-256-60hz.toml >/tmp/c256-s$s.toml
    for p in block-jacobi multigrid; do
      row "31-stiff-$p" $H /tmp/c256-s$s.toml --preconditioner $p --steps $((4 * s)) --batch $s
    done
  done
  row "31-own" $H cloth-256 --integrator implicit --steps 400 --batch 20
  # Issue 31: the implicit CPU path from 1 to 16 threads on cloth-256 (goal >= 6x), at its own
  # step and at one step per frame (multigrid by size; the CPU's loops on the pool).
  for t in 1 16; do
    export RAYON_NUM_THREADS=$t
    row "31-cpu-t$t" $H cloth-256 --integrator implicit --backend cpu --steps 40 --batch 20
    row "31-cpu-t$t" $H bench/scenes/cloth-256-60hz.toml --backend cpu --steps 6 --batch 1
    unset RAYON_NUM_THREADS
  done
  # Issue 31's jello goal (>= 600 steps/s converged) with each preconditioner in the
  # one-workgroup step, two rounds interleaved.
  for r in 1 2; do
    for p in block-jacobi multigrid; do
      for s in jello cloth hair; do
        row "31-group-$p" $H bench/scenes/$s-60hz.toml --integrator implicit --preconditioner $p --steps 120 --batch 1
      done
      row "31-group-$p" $H bench/scenes/jello-60hz.toml --integrator bdf2 --preconditioner $p --steps 120 --batch 1
    done
  done
  if [ -f .gpu/ex/preconditioners.xz ]; then
    xz -dc .gpu/ex/preconditioners.xz >/tmp/preconditioners && chmod +x /tmp/preconditioners
    f=0.016666666666666666
    timeout 120 /tmp/preconditioners bench/scenes/cloth-256-60hz.toml $f 30 2 both implicit gpu
    timeout 120 /tmp/preconditioners /tmp/peer-cloth-256-60hz.toml $f 60 2 both bdf2 gpu
    # The one-workgroup step with each preconditioner (issue 31: the cycle in
    # one workgroup, mg_implicit_step), the small scenes at one step per frame.
    for s in jello cloth hair jello-sphere; do
      timeout 60 /tmp/preconditioners $s $f 60 3 both implicit gpu group
    done
    timeout 60 /tmp/preconditioners jello $f 60 3 both bdf2 gpu group
  fi
  ;;
bisect)
  # Self-collision scenes for each binary in .gpu/bis/<commit>.xz, three interleaved rounds.
  for f in .gpu/bis/*.xz; do c=$(basename $f .xz); xz -dc $f >/tmp/hb-$c && chmod +x /tmp/hb-$c; done
  for r in 1 2 3; do for f in .gpu/bis/*.xz; do
    c=$(basename $f .xz)
    row "bis-$c" /tmp/hb-$c examples/scenes/cloth-fold.toml --steps 6000 --batch 1000
    row "bis-$c" /tmp/hb-$c examples/scenes/pile.toml --steps 9600 --batch 1000
  done; done
  ;;
s)
  "$H" check cloth | grep -E "adapter|fused_frame|GPU step"
  old=/tmp/hooke-old
  [ -x $old ] || { xz -dc .gpu/old/hooke.xz >$old && chmod +x $old; }
  # A third binary, .gpu/v1/hooke.xz, where one travels (an earlier state of this work).
  tags="old new"
  [ -f .gpu/v1/hooke.xz ] && xz -dc .gpu/v1/hooke.xz >/tmp/hooke-v1 && chmod +x /tmp/hooke-v1 &&
    tags="old v1 new"
  for r in 1 2 3; do for tag in $tags; do
    b=$old
    [ $tag = new ] && b=$H
    [ $tag = v1 ] && b=/tmp/hooke-v1
    row "29-$tag" $b hair --steps 40000 --batch 2000
    row "29-$tag" $b jello --steps 40000 --batch 2000
    row "29-$tag" $b cloth --steps 20000 --batch 2000
    row "29-$tag" $b bench/scenes/warp-cloth-32.toml --steps 960 --batch 16
  done; done
  ;;
a)
  nvidia-smi -L
  "$H" check cloth-1024 | grep -iE "adapter|fits"
  issue29
  for s in jello cloth-256 hair cloth; do
    row "31-60hz" $H bench/scenes/$s-60hz.toml --integrator implicit --steps 120 --batch 1
    row "31-60hz" $H bench/scenes/$s-60hz.toml --integrator vbd --steps 600 --batch 60
  done
  row "31-60hz" $H bench/scenes/jello-60hz.toml --integrator implicit --backend cpu --steps 60 --batch 1
  peer60 64
  peer60 256
  ;;
b)
  issue29
  for s in 256 1024; do
    d=10
    [ $s = 1024 ] && d=0.5
    /usr/bin/time -f "run cloth-$s --duration $d --save: %e s wall, %M KB peak" \
      timeout 150 "$H" run cloth-$s --duration $d --save /tmp/c$s.rrd 2>&1 | tail -3
    ls -la /tmp/c$s.rrd
    rm -f /tmp/c$s.rrd
  done
  for t in 1 4 16; do
    export RAYON_NUM_THREADS=$t; row "31-threads-$t" $H bench/scenes/cloth-256-60hz.toml \
      --integrator implicit --backend cpu --steps 3 --batch 1
  done
  ;;
c)
  mkdir -p /tmp/site
  [ -d /tmp/site/warp ] || cat /tmp/parts/warp.part.* | xz -d | tar xf - -C /tmp/site
  [ -d /tmp/site/taichi ] || python3 -m pip install -q --no-index --no-deps --no-compile \
    --target /tmp/site .gpu/w3/*.whl
  export PYTHONPATH=/tmp/site PYTHONUNBUFFERED=1
  P=$PWD/$G/peers
  for r in 1 2; do for n in 64 256 1024; do
    s=$([ $n -ge 1024 ] && echo 2000 || echo 5000)
    f=/tmp/peer-cloth-$n.toml
    [ -f $f ] || sed "s/256/$n/g; s/255/$((n - 1))/; s/65.536/$(python3 -c "print($n*$n/1000)")/" \
      $P/peer-cloth-256.toml >$f
    for m in scatter gather; do
      (cd $P && timeout 100 python3 bench_warp.py --device cuda --n $n --mode $m --steps $s 2>&1 |
        grep -m2 '^\[warp' | tail -1)
      (cd $P && timeout 100 python3 bench_taichi.py --device cuda --n $n --mode $m --steps $s 2>&1 |
        grep -m2 '^\[taichi' | tail -1)
    done
    row "peers-$r" $H $f --steps $s --batch 500
    tail -1 "$rows" | python3 -c 'import json,sys; r=json.load(sys.stdin)["result"]; print("[hooke]", r["scene"], "%.3e spring updates/s" % r["spring_updates_per_sec"]["median"])'
  done; done
  ;;
esac
python3 bench/device/summarize.py "$rows"
