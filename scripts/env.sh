# Sourced by the scripts: environment for running glyptic and its tests headless.
# lavapipe/llvmpipe want a runtime dir; without one Vulkan prints a harmless warning.
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
  export XDG_RUNTIME_DIR="${TMPDIR:-/tmp}/glyptic-xdg-$(id -u)"
  mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
fi
# ONNX Runtime's telemetry uploader off for everything run from here (the examples and the
# in-process tests load it too; the glyptic binary sets this itself).
export ORT_DISABLE_TELEMETRY=1
