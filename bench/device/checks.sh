# What wgpu's runtime checks cost each kind of step (examples/shader_checks.rs), on a GPU machine,
# carrying [".gpu/p", ".gpu/gl", ".gpu/ex"], .gpu/ex holding shader_checks.xz:
#   strip -o /tmp/sc2 target/release/examples/shader_checks && xz -6 -c /tmp/sc2 >.gpu/ex/shader_checks.xz
. .gpu/p/env.sh 2>/dev/null
nvidia-smi -L
xz -dc .gpu/ex/shader_checks.xz >/tmp/shader_checks && chmod +x /tmp/shader_checks
f=0.016666666666666666
run() { timeout 90 /tmp/shader_checks "$@" 2>&1 | tail -4; }

run bench/scenes/jello-60hz.toml implicit $f 60 3 1
run bench/scenes/jello-60hz.toml vbd $f 60 3 1
run bench/scenes/cloth-60hz.toml implicit $f 60 3 1
run bench/scenes/cloth-256-60hz.toml implicit $f 20 2 1
run hair - - 40000 3 2000
run jello - - 40000 3 2000
run cloth-64 - - 20000 3 1000
run cloth-256 - - 5000 3 1000
run cloth-1024 - - 1000 3 500
run examples/scenes/cloth-fold.toml - - 6000 3 1000
run jello xpbd - 20000 3 2000

