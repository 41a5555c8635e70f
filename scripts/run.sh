#!/usr/bin/env bash
# Set everything up (scripts/setup.sh), then open the editor on the bundled sample.
# Without a display (no DISPLAY or WAYLAND_DISPLAY, as on CI) it says so and renders the sample to
# out/ribbon.png instead; `bash scripts/run.sh --render` does that on a desktop too.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh

sample=resources/samples/ribbon.xml
if [[ "${1:-}" != "--render" && ( -n "${DISPLAY:-}" || -n "${WAYLAND_DISPLAY:-}" ) ]]; then
    printf 'run: opening the editor on %s\n' "$sample"
    exec .venv/bin/fmr-editor "$sample"
fi

if [[ "${1:-}" != "--render" ]]; then
    printf 'run: no display (DISPLAY and WAYLAND_DISPLAY are unset), so the editor cannot open here;\n'
    printf 'run: rendering the sample headless instead (for the editor: run on a desktop, or xvfb-run bash scripts/run.sh)\n'
fi
mkdir -p out
.venv/bin/fmr-editor render "$sample" -o out/ribbon.png
printf 'run: wrote %s\n' "$(pwd)/out/ribbon.png"
