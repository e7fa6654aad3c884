#!/usr/bin/env bash
# Regenerate docs/images/plybook_cover.png and docs/images/plybook_page.png: the bundled 24-ply job
# solved, its ply book's cover and the page of its second ply (needs pdftoppm: apt-get install
# poppler-utils).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=$(mktemp -d)
.venv/bin/python -m flatweave solve resources/jobs/dome-laminate.toml --out "$out/dome.flatweave" \
    --ply-book "$out/book.pdf" --quiet
pdftoppm -png -r 60 -f 1 -l 1 -singlefile "$out/book.pdf" docs/images/plybook_cover
pdftoppm -png -r 60 -f 3 -l 3 -singlefile "$out/book.pdf" docs/images/plybook_page
ls -la "$out"
