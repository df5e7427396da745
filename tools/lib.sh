# Helpers shared by the shell scripts of tools/ (source it: `. tools/lib.sh`).

# The repository's tests/data/jobs, the job files shared with the Rust tests
# (tests/common/job.rs) and the Python scripts (tools/fixtures.py).
jobs_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/tests/data/jobs"

# job_fixture NAME KEY=VALUE...: prints tests/data/jobs/NAME with each @KEY@
# replaced by VALUE. Fails if a key does not occur or a placeholder is left
# unfilled, so a template and its callers cannot drift apart.
job_fixture() {
    local name="$1" text kv key value
    shift
    text="$(cat "$jobs_dir/$name")" || return 1
    for kv in "$@"; do
        key="@${kv%%=*}@"
        value="${kv#*=}"
        if [[ "$text" != *"$key"* ]]; then
            echo "job_fixture: $name has no $key" >&2
            return 1
        fi
        text="${text//"$key"/"$value"}"
    done
    if [[ "$text" =~ @[A-Z0-9_]+@ ]]; then
        echo "job_fixture: $name: ${BASH_REMATCH[0]} is not filled in" >&2
        return 1
    fi
    printf '%s\n' "$text"
}

# peers_venv VENV: makes (or reuses) the Python venv of the peer comparisons
# (tools/python_peers.sh, tools/hydro_peers.sh): pysheds and xarray-spatial
# from PyPI, and py-richdem, built from its 0.3.4 sdist with the current
# pybind11 headers when `pip install richdem` fails (it does on Python >=
# 3.11). Writes how richdem was installed, or why not, to VENV/richdem-install.txt.
# Versions: pysheds 0.5 calls np.in1d and richdem 0.3.4 is built against
# numpy 1, so numpy < 2, and with it pandas < 3, scipy < 1.15,
# scikit-image < 0.25. Env: PYTHON (default python3), RICHDEM_BUILD_TIMEOUT
# (seconds, default 900).
peers_venv() {
    local venv="$1" vpy status log tmp
    if [ ! -x "$venv/bin/python" ]; then
        echo "== venv $venv"
        "${PYTHON:-python3}" -m venv "$venv"
    fi
    vpy="$venv/bin/python"
    "$vpy" -m pip install -q --upgrade pip
    echo "== pysheds, xarray-spatial (PyPI)"
    "$vpy" -m pip install -q pysheds xarray-spatial 'numpy<2' 'pandas<3' 'scipy<1.15' 'scikit-image<0.25'
    status="$venv/richdem-install.txt"
    if "$vpy" -c 'import richdem' 2>/dev/null; then
        echo "richdem: installed ($("$vpy" -m pip show richdem 2>/dev/null | sed -n 's/^Version: //p'))" >"$status"
        return 0
    fi
    echo "== richdem: pip install richdem, else the sdist with current pybind11 headers"
    log="$venv/richdem-build.log"
    tmp=$(mktemp -d)
    if timeout "${RICHDEM_BUILD_TIMEOUT:-900}" "$vpy" -m pip install richdem >"$log" 2>&1; then
        echo "richdem: installed from PyPI as is" >"$status"
    elif timeout "${RICHDEM_BUILD_TIMEOUT:-900}" bash -c '
            set -e
            "$0" -m pip install -q pybind11 setuptools wheel
            "$0" -m pip download richdem==0.3.4 --no-deps --no-binary :all: -d "$1"
            cd "$1" && tar xzf richdem-0.3.4.tar.gz && cd richdem-0.3.4
            rm -rf lib/pybind11
            cp -r "$("$0" -c "import pybind11; print(pybind11.get_include())")/pybind11" lib/
            "$0" -m pip install --no-build-isolation .
        ' "$vpy" "$tmp" >>"$log" 2>&1 && "$vpy" -c 'import richdem' 2>>"$log"; then
        echo "richdem: built from the 0.3.4 sdist with pybind11 $("$vpy" -c 'import pybind11; print(pybind11.__version__)') headers" >"$status"
    else
        echo "richdem: could not be installed (pip install richdem and the sdist rebuild both failed; last lines of $log: $(tail -n 3 "$log" | tr '\n' ' '))" >"$status"
    fi
    rm -rf "$tmp"
}
