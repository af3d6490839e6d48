#!/usr/bin/env bash
# Debian 12's own lavapipe (Mesa 22.3, what `apt-get install mesa-vulkan-drivers` gives there)
# beside whatever Mesa the system has, for checking a change on both drivers without `.ci/run`'s
# downgrade and upgrade (docs/drivers.md). Prints the path of a Vulkan ICD file for it:
#
#   export VK_ICD_FILENAMES=$(bash bench/mesa22_icd.sh)
#   cargo run --release --example backends_agree -- cloth implicit 0.016666667 60
#
# DIR (the first argument, default ~/.cache/hooke/mesa22) keeps the extracted package; a second
# call reuses it. Needs Debian 12's apt sources; the driver's own libraries (LLVM 15) are the
# system's.
set -euo pipefail
dir=${1:-${XDG_CACHE_HOME:-$HOME/.cache}/hooke/mesa22}
icd=$dir/lvp22_icd.json
lib=$dir/root/usr/lib/x86_64-linux-gnu/libvulkan_lvp.so
if [[ ! -f $lib ]]; then
  mkdir -p "$dir"
  (cd "$dir" && apt-get download -qq mesa-vulkan-drivers/bookworm >/dev/null 2>&1) || {
    echo "mesa22_icd: apt-get download mesa-vulkan-drivers/bookworm failed (Debian 12's sources needed)" >&2
    exit 1
  }
  dpkg -x "$dir"/mesa-vulkan-drivers_22.3*.deb "$dir/root"
fi
version=$(dpkg-deb -f "$dir"/mesa-vulkan-drivers_22.3*.deb Version)
cat > "$icd" <<JSON
{
    "ICD": { "api_version": "1.1.230", "library_path": "$lib" },
    "file_format_version": "1.0.0",
    "comment": "mesa-vulkan-drivers $version, extracted by bench/mesa22_icd.sh"
}
JSON
echo "$icd"
