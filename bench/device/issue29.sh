#!/usr/bin/env bash
# Issue 29's GPU rows in one call on a lent GPU machine: this checkout's binary ($H, from
# ../shared/gpu/kit.sh) against a baseline binary (.gpu/old/hooke.gz, e.g. main at 0fbce83,
# before the grid stencils, the one-workgroup steps and the lighter stage slots), interleaved,
# two rounds, one JSON line per run into $OUT/issue29.jsonl, then a table (summarize.py).
# From the project root, carrying [".gpu/bin", ".gpu/gl", ".gpu/old"]:
#   bash bench/device/issue29.sh
# Build the baseline here first (it shares target/, so only hooke itself recompiles):
#   git worktree add /tmp/old 0fbce83 && (cd /tmp/old && CARGO_TARGET_DIR=$PWD/target \
#     cargo build --release --locked -q) && mkdir -p .gpu/old && \
#     strip -o .gpu/old/hooke target/release/hooke && gzip -f .gpu/old/hooke && \
#     ../shared/gpu/kit.sh      # rebuilds this checkout's binary into .gpu/bin
set -u
. .gpu/bin/env.sh
OLD=/tmp/hooke-old
[ -x "$OLD" ] || { gunzip -c .gpu/old/hooke.gz >"$OLD" && chmod +x "$OLD"; }
out=${OUT:-/tmp}/issue29.jsonl
: >"$out"
"$H" check cloth-1024 | grep -iE "adapter|fits"
nvidia-smi -L 2>/dev/null
for round in 1 2; do
  for tag in old new; do
    b=$OLD; [ "$tag" = new ] && b=$H
    run() {
      local line
      line=$("$b" bench throughput "$@" --json --repeat 3 2>/dev/null | head -1)
      [ -n "$line" ] && echo "{\"round\":$round,\"binary\":\"$tag\",\"args\":\"$*\",\"result\":$line}" >>"$out"
    }
    run hair --steps 40000 --batch 2000
    run jello --steps 40000 --batch 2000
    run cloth --steps 20000 --batch 2000
    run cloth-64 --steps 20000 --batch 1000
    run cloth-256 --steps 5000 --batch 1000
    run cloth-1024 --steps 1000 --batch 500
    run bench/scenes/warp-cloth-64.toml --steps 960 --batch 16
    run examples/scenes/cloth-fold.toml --steps 6000 --batch 1000
    run jello --integrator xpbd --steps 20000 --batch 2000
  done
done
python3 bench/device/summarize.py "$out"
