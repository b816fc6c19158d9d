#!/usr/bin/env bash
# Renders every scene in scenes/ in every integrator × spectral mode with two spectrace
# binaries and compares the outputs byte for byte (EXR, PNG, spectral EXR). Used to show
# that a refactoring changes no rendered number.
#
#   xtask/compare/same_renders.sh OLD_BINARY NEW_BINARY [OUT_DIR]
#
# Prints one line per render: "same" or "DIFFERENT" (with `cargo xtask exr-diff`'s largest
# difference for each EXR that differs); exits 1 if any differ. A render that
# fails must fail with both binaries (its error text is compared instead).
set -uo pipefail
old=$1 new=$2 out=${3:-target/same-renders}
cd "$(dirname "$0")/../.."
root=$PWD
cargo build -q --release -p xtask
rm -rf "$out"; mkdir -p "$out/old" "$out/new"
scenes=(default $(ls scenes/*/*.json scenes/*/*.gltf scenes/*/*.obj | grep -v 'reference/prism.obj'))
modes=(
  "--integrator whitted-hall --spectral rgb"
  "--integrator whitted-hall --spectral auto"
  "--integrator whitted-hall --spectral bins:16 --spectral-exr S"
  "--integrator whitted-hall --spectral bins:95 --spp 2"
  "--integrator path --spectral rgb --spp 4"
  "--integrator path --spectral auto --spp 4"
  "--integrator path --spectral bins:16 --spp 4 --spectral-exr S"
  "--integrator path --spectral hero:4 --spp 4"
  "--integrator path --spectral hero:8 --spp 3 --wavelength-pdf visible"
)
differ=0 count=0
for scene in "${scenes[@]}"; do
  for mi in "${!modes[@]}"; do
    tag="$(echo "$scene" | tr '/.' '__')_$mi"
    for side in old new; do
      bin=$old; [ $side = new ] && bin=$new
      args=(render -q --width 48 --height 36 --seed 7 --threads 2 -o "$out/$side/$tag.exr")
      [ "$scene" != default ] && args+=("$scene")
      mode=${modes[$mi]//S/$out/$side/${tag}_spectral.exr}
      # shellcheck disable=SC2206
      args+=($mode)
      "$bin" "${args[@]}" > "$out/$side/$tag.log" 2>&1; echo "exit $?" >> "$out/$side/$tag.log"
    done
    count=$((count + 1))
    same=1
    for f in "$out/old/$tag"*; do
      g="$out/new/${f#"$out/old/"}"
      if ! cmp -s "$f" "$g"; then
        same=0
        case $f in *.exr) echo "  ${f#"$out/old/"}: $("$root/target/release/xtask" exr-diff "$f" "$g" 2>&1 | tail -1)" ;; esac
      fi
    done
    if [ $same = 1 ]; then echo "same       $scene ${modes[$mi]}"; else echo "DIFFERENT  $scene ${modes[$mi]}"; differ=$((differ + 1)); fi
  done
done
echo "$((count - differ)) same, $differ different (of $count renders)"
[ $differ = 0 ]
