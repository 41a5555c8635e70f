#!/usr/bin/env bash
# Set everything up (scripts/setup.sh), then render the bundled sample to out/ribbon.png.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh

mkdir -p out
.venv/bin/fmr-editor render resources/samples/ribbon.xml -o out/ribbon.png
printf 'run: wrote %s\n' "$(pwd)/out/ribbon.png"
