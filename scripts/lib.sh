# Shell functions shared by the scripts in scripts/ (sourced, not run).

# install_missing_packages PKG...: apt-get installs those of the Debian packages that are not
# installed yet (as root, or through sudo); nothing when all are there.
install_missing_packages() {
  local missing=() p SUDO=""
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -gt 0 ] || return 0
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# use_lavapipe_unless_chosen: points the Vulkan loader at Mesa's lavapipe (the CPU driver) for
# what runs next, unless the caller already chose a driver (VK_DRIVER_FILES / VK_ICD_FILENAMES).
use_lavapipe_unless_chosen() {
  local lvp
  lvp=$(ls /usr/share/vulkan/icd.d/lvp_icd.*.json 2>/dev/null | head -n 1 || true)
  if [ -n "$lvp" ] && [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]; then
    export VK_DRIVER_FILES="$lvp" VK_ICD_FILENAMES="$lvp"
  fi
}
