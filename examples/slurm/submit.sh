#!/bin/sh
# Render SCENE at SPP samples per pixel as PARTS Slurm array tasks and merge them:
#   examples/slurm/submit.sh scene.json 256 8 [extra render options…]
# Run it in the folder that is to receive the films and render.exr/.png (shared by the nodes).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
scene=$1 spp=$2 parts=$3
shift 3
export SCENE="$scene" SPP="$spp" PARTS="$parts" RENDER_ARGS="$*"
array=$(sbatch --parsable --array=1-"$parts" --export=ALL "$here/render.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" --export=ALL "$here/merge.sbatch")
echo "array job $array ($parts parts), merge job ${merge%%;*} after it"
