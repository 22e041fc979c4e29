#!/usr/bin/env bash
# The main job: installs what is missing, builds the host preset and runs the end-to-end demo
# in simulation. Outputs go to out/demo/ (or $1).
#
# What runs today (grows with the project, see README "Status"):
#   1. the paper rig (Tables 2-4) as a rig file, 2. its parameter blob, 3. the blob checked and
#   printed back.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset host >/dev/null
cmake --build --preset host -j "$(nproc)"

out=${1:-out/demo}
bin=build/host/bin
mkdir -p "${out}"
echo "== 1. paper rig -> ${out}/paper-rig.yaml" >&2
"${bin}/mfns-calib" paper-rig --out "${out}/paper-rig.yaml"
echo "== 2. parameter blob -> ${out}/calibration.bin" >&2
"${bin}/mfns-calib" blob "${out}/paper-rig.yaml" --out "${out}/calibration.bin" --generation 1
echo "== 3. blob read back" >&2
"${bin}/mfns-calib" inspect "${out}/calibration.bin"
echo "demo: done (outputs in ${out})" >&2
