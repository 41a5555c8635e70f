#!/usr/bin/env bash
# Set everything up (scripts/setup.sh), then run pytest: the whole suite (on every core), or the given
# arguments, e.g. `bash scripts/test.sh tests/test_layers.py -k layers`. Exits with pytest's code; "no tests
# collected" (pytest's 5) counts as a failure.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh

# The whole suite runs on every core (pytest-xdist: each worker has its own Xvfb, see tests/conftest.py): 4.4
# minutes instead of 6.5 on 2 cores. Given arguments, pytest runs them as asked, in one process.
if (($# == 0)); then
    set -- -n auto
fi
rc=0
.venv/bin/python -m pytest -q "$@" || rc=$?
if ((rc == 5)); then
    printf 'test: FAILED: pytest collected no tests (exit code 5); this counts as a failure\n' >&2
fi
exit "$rc"
