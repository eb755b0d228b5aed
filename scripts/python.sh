# Sourced by the other scripts: picks the Python that rtlab is installed into.
# $PYTHON wins; then a project venv; a system Python that refuses pip installs
# (Debian/Ubuntu's "externally managed" one) gets a fresh .venv instead.
PY=${PYTHON:-python3}
if [ -z "${PYTHON:-}" ]; then
    if [ -x .venv/bin/python ]; then
        PY=.venv/bin/python
    elif [ -f "$($PY -c 'import sysconfig; print(sysconfig.get_path("stdlib"))')/EXTERNALLY-MANAGED" ]; then
        if ! $PY -m venv .venv 2>/dev/null; then
            SUDO=""
            [ "$(id -u)" -eq 0 ] || SUDO=sudo
            $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq python3-venv >/dev/null
            rm -rf .venv
            $PY -m venv .venv
        fi
        PY=.venv/bin/python
    fi
fi
