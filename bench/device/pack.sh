#!/usr/bin/env bash
# What `gpu_rows.sh v` carries in .gpu/t: this checkout's hooke, a baseline's (the commit given)
# and the GPU test binaries, stripped, in one xz stream with a window wide enough to span them
# all. From the project root, after `cargo test --release --locked --no-run`:
#   bench/device/pack.sh 77e1e67
# (TESTS="gpu vbd" packs those test binaries alone.)
set -eu
base=${1:?the baseline commit}
root=$(git rev-parse --show-toplevel)
cd "$root"
ex=$(git rev-parse --git-path info/exclude)
grep -qx '/.gpu/' "$ex" 2>/dev/null || echo '/.gpu/' >>"$ex"
# The baseline builds in its own target folder seeded from ours: a target shared between two
# checkouts can keep a stale binary (cargo compares file times).
[ -d /tmp/old ] || git worktree add -f /tmp/old "$base"
[ -d /tmp/bt ] || cp -a target /tmp/bt
(cd /tmp/old && CARGO_TARGET_DIR=/tmp/bt cargo build --release --locked -q)
rm -rf /tmp/pack && mkdir -p /tmp/pack/tests
strip -o /tmp/pack/hooke target/release/hooke
strip -o /tmp/pack/hooke-old /tmp/bt/release/hooke
# A third binary where one is named (V1=path: an earlier state of this work).
[ -n "${V1:-}" ] && strip -o /tmp/pack/hooke-v1 "$V1"
for t in ${TESTS:-gpu gpu_implicit gpu_fused vbd xpbd effects self_collision hard_cases hard_limits energy}; do
  strip -o /tmp/pack/tests/$t "$(ls -t target/release/deps/$t-* | grep -v '\.d$' | head -1)"
done
mkdir -p .gpu/t
(cd /tmp/pack && tar cf - hooke* tests | xz -T1 --lzma2=preset=9,dict=256MiB) >.gpu/t/kit.tar.xz
mkdir -p .gpu/p && cp ../shared/gpu/env.sh .gpu/p/ && cp -r ../shared/peers .gpu/p/peers
ls -la .gpu/t/kit.tar.xz
