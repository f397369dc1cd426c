# Sourced by the set-up scripts: `apt_install PKG...` installs Debian packages quietly,
# refreshing the package lists once per shell first.
apt_install() {
  echo "installing $* (apt-get)" >&2
  if [ -z "${SRG_APT_UPDATED:-}" ]; then
    apt-get update -qq
    export SRG_APT_UPDATED=1
  fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}
