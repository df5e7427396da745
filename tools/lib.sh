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
