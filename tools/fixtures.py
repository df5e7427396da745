"""Job files of tests/data/jobs, shared with the Rust tests (tests/common/job.rs).

A job file there is a template: each `@KEY@` stands for a path or size the
caller chooses. `job("NAME.toml", KEY=value, ...)` returns its text filled
in; a key that does not occur, or a placeholder left unfilled, is an error,
so a template and its callers cannot drift apart.
"""

import os
import re

JOBS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "data", "jobs")

# Capitals, digits and `_` between two `@`; a step reference such as
# "@filled" is none.
PLACEHOLDER = re.compile(r"@[A-Z0-9_]+@")


def job(name, **values):
    with open(os.path.join(JOBS, name), encoding="utf-8") as f:
        text = f.read()
    for key, value in values.items():
        mark = f"@{key}@"
        if mark not in text:
            raise KeyError(f"{name} has no {mark}")
        text = text.replace(mark, str(value))
    left = PLACEHOLDER.search(text)
    if left:
        raise KeyError(f"{name}: {left.group(0)} is not filled in")
    return text
