#!/usr/bin/env bash
# Regenerate the README's export example and docs/images/export_overview.png
# (needs pdftoppm: apt-get install poppler-utils).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=$(mktemp -d)
.venv/bin/python -m flatweave flatten octant --spacing 0.025 \
    --plane-dart "1,-1,0,0:-2,2,-2,2,-2,0.55" --units m --seam-allowance 10 --paper a4 \
    --export "$out/octant.dxf" --export "$out/octant.svg" --export "$out/octant.pdf" \
    --export "$out/octant.vtp" --export "$out/octant.obj" --out "$out/octant.json"
pdftoppm -png -r 72 -f 1 -l 1 -singlefile "$out/octant.pdf" docs/images/export_overview
ls -la "$out"
