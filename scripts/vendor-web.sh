#!/usr/bin/env bash
# Checks (default) or refreshes (--update) the dashboard's vendored libraries in
# server/web/vendor/ against their npm releases: `npm pack` of the pinned versions, the tarballs'
# sha512 integrity compared with the pinned values, then the files compared with (or copied
# to) server/web/vendor/. Needs npm and the npm registry; the build and CI do not run it (the
# files are committed, and the build checks them against server/web/vendor/SHA256SUMS).
#   bash scripts/vendor-web.sh [--update]
set -euo pipefail
cd "$(dirname "$0")/.."
MODE=${1:-check}
VENDOR=server/web/vendor
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# name@version | pinned integrity | vendor dir | files in the tarball (package/...) to vendor
PACKAGES=(
  "uplot@1.6.32|sha512-KIMVnG68zvu5XXUbC4LQEPnhwOxBuLyW1AHtpm6IKTXImkbLgkMy+jabjLgSLMasNuGGzQm/ep3tOkyTxpiQIw==|uplot-1.6.32|dist/uPlot.iife.min.js dist/uPlot.min.css LICENSE"
  "@cfworker/json-schema@4.1.6|sha512-YzVGTHXf4bzlyAL5KAvHYCdNbbt6zM5cYkAgxqxQPDQM6aZ4ShIIN5yJ+6q7YeonnevxT8k/LmD2tJi/jOiKkg==|cfworker-json-schema-4.1.6|dist/esm/deep-compare-strict.js dist/esm/dereference.js dist/esm/format.js dist/esm/index.js dist/esm/pointer.js dist/esm/types.js dist/esm/ucs2-length.js dist/esm/validate.js dist/esm/validator.js"
)

status=0
for entry in "${PACKAGES[@]}"; do
  IFS='|' read -r spec integrity dir files <<<"$entry"
  (cd "$TMP" && npm pack --silent "$spec" >"$TMP/name")
  tgz="$TMP/$(tail -1 "$TMP/name")"
  got="sha512-$(openssl dgst -sha512 -binary "$tgz" | base64 -w0)"
  if [ "$got" != "$integrity" ]; then
    echo "vendor-web: $spec: integrity $got differs from the pinned $integrity" >&2
    exit 1
  fi
  rm -rf "$TMP/package" && tar xzf "$tgz" -C "$TMP"
  for f in $files; do
    dest="$VENDOR/$dir/$(basename "$f")"
    if [ "$MODE" = "--update" ]; then
      mkdir -p "$VENDOR/$dir" && cp "$TMP/package/$f" "$dest"
    elif ! cmp -s "$TMP/package/$f" "$dest"; then
      echo "vendor-web: $dest differs from $spec's $f" >&2
      status=1
    fi
  done
  echo "vendor-web: $spec ok ($integrity)"
done
if [ "$MODE" = "--update" ]; then
  (cd "$VENDOR" && sha256sum */* | grep -v ' README.md$' >SHA256SUMS)
  echo "vendor-web: rewrote $VENDOR/SHA256SUMS (the licence of a package without one, e.g." \
       "cfworker's LICENSE.md, is kept from its repository)"
fi
exit $status
