#!/usr/bin/env bash
# Does the built wheel work on a machine without Rust? A fresh virtual
# environment in a temp dir, the wheel pip-installed into it with numpy (all
# that the README's example needs), then README.md's Python example -- the
# ```python block right after the `<!-- python-example ... -->` marker in the
# "From Python" section, extracted exactly as written -- run in an empty temp
# directory under `env -i` with only the venv, /usr/bin and /bin on PATH (no
# cargo, no rustc, no PYTHONPATH). Exits non-zero if any step fails.
#
# Usage: bash python/wheel_check.sh [WHEEL]
#   WHEEL  a built wheel (e.g. /work/wheels/orogen-0.1.0-cp39-abi3-*.whl).
#          Without it, one is built first with `maturin build --release`
#          from python/ into a temp dir (maturin from PATH, else installed
#          into a throwaway venv; this needs cargo).
# Env:   PYTHON  the interpreter for the venv (default python3).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
readme="$here/../README.md"
PY=${PYTHON:-python3}
work=$(mktemp -d "${TMPDIR:-/tmp}/orogen-wheel-check.XXXXXX")
trap 'rm -rf "$work"' EXIT
start=$(date +%s)

wheel=${1:-}
if [ -z "$wheel" ]; then
    echo "== no wheel given: maturin build --release into $work/wheels"
    if command -v maturin >/dev/null 2>&1; then
        maturin_bin=$(command -v maturin)
    else
        "$PY" -m venv "$work/build-venv"
        "$work/build-venv/bin/python" -m pip install -q maturin
        maturin_bin="$work/build-venv/bin/maturin"
    fi
    (cd "$here" && "$maturin_bin" build --release -q -o "$work/wheels")
    wheel=$(ls "$work"/wheels/orogen-*.whl | head -n 1)
fi
[ -f "$wheel" ] || { echo "wheel_check: no such wheel: $wheel" >&2; exit 1; }
wheel=$(cd "$(dirname "$wheel")" && pwd)/$(basename "$wheel")
echo "== wheel: $wheel"

# The README's example, exactly as written.
example="$work/readme_example.py"
awk '
    found == 0 && /^<!-- python-example/ { found = 1; next }
    found == 1 { if ($0 == "```python") { found = 2; next } else { exit 3 } }
    found == 2 && /^```[[:space:]]*$/ { found = 3; exit }
    found == 2 { print }
    END { if (found != 3) exit 3 }
' "$readme" >"$example" || {
    echo "wheel_check: no \`<!-- python-example -->\` marker followed by a closed \`\`\`python block in $readme" >&2
    exit 1
}
[ -s "$example" ] || { echo "wheel_check: the README's Python example is empty" >&2; exit 1; }
echo "== README example: $(wc -l <"$example") lines"

echo "== fresh venv: $work/venv ($("$PY" --version 2>&1))"
"$PY" -m venv "$work/venv"
vpy="$work/venv/bin/python"
"$vpy" -m pip install -q --upgrade pip
"$vpy" -m pip install -q "$wheel" numpy
"$vpy" -m pip list --format=freeze 2>/dev/null | grep -Ei '^(orogen|numpy)=' | sed 's/^/   /'

run="$work/run"
mkdir "$run"
cp "$example" "$run/example.py"
clean_env=(env -i "PATH=$work/venv/bin:/usr/bin:/bin" "HOME=$run" "TMPDIR=$run" "LANG=C.UTF-8")

# No Rust on that PATH, and orogen comes from the installed wheel, not a source tree.
if (cd "$run" && "${clean_env[@]}" sh -c 'command -v cargo || command -v rustc || command -v maturin') >/dev/null; then
    echo "wheel_check: a Rust toolchain or maturin is on the clean PATH" >&2
    exit 1
fi
where=$(cd "$run" && "${clean_env[@]}" python -c 'import orogen, os; print(os.path.dirname(orogen.__file__))')
case "$where" in
    "$work/venv/"*) echo "== orogen imported from $where" ;;
    *) echo "wheel_check: orogen was imported from $where, not the venv" >&2; exit 1 ;;
esac

echo "== running the README example in $run (env -i, PATH=venv:/usr/bin:/bin)"
(cd "$run" && "${clean_env[@]}" python example.py) || {
    echo "wheel_check: the README's Python example failed (exit $?)" >&2
    exit 1
}
for f in dem.tif filled.tiles; do
    [ -e "$run/$f" ] || { echo "wheel_check: the example did not write $f" >&2; exit 1; }
done
echo "wheel check passed in $(( $(date +%s) - start )) s"
