# Sourced by the gallery and screenshot scripts: fetch_astronaut DEST writes NASA's portrait of
# astronaut Eileen Collins (public domain) to DEST, taken from the scikit-image wheel on PyPI
# (cached in .deps/cache); a DEST already there is kept.
fetch_astronaut() {
  local dest="$1" cache=.deps/cache whl
  [ -s "$dest" ] && return 0
  mkdir -p "$cache" "$(dirname "$dest")"
  whl=$(ls "$cache"/scikit_image-*.whl 2>/dev/null | head -n1 || true)
  if [ -z "$whl" ]; then
    python3 -m pip download --quiet --no-deps --only-binary=:all: -d "$cache" \
      --python-version 3.11 --implementation cp --platform manylinux_2_17_x86_64 \
      scikit-image==0.24.0 >&2
    whl=$(ls "$cache"/scikit_image-*.whl | head -n1)
  fi
  python3 - "$whl" "$dest" <<'PYEOF'
import shutil, sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z, z.open("skimage/data/astronaut.png") as s, open(sys.argv[2], "wb") as d:
    shutil.copyfileobj(s, d)
PYEOF
}
