# Debian packages for the project's scripts (sourced, not run).
# apt_ensure TAG PKG...: installs those of PKG... that are not installed yet (with sudo when not
# root) and says so, prefixed with TAG; says they are present otherwise. Idempotent.
apt_ensure() {
  local tag="$1" p SUDO=""
  shift
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ "${#missing[@]}" -eq 0 ]; then
    printf '%s: Debian packages present\n' "$tag"
    return 0
  fi
  printf '%s: installing Debian packages: %s\n' "$tag" "${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    if ! command -v sudo >/dev/null; then
      printf '%s: error: need root or sudo to install: %s\n' "$tag" "${missing[*]}" >&2
      return 1
    fi
    SUDO="sudo"
  fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}
