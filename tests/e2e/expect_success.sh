#!/usr/bin/env bash
# expect_success.sh REGEX COMMAND...: passes when COMMAND exits 0 and its output (stdout and
# stderr together, in whatever order MPI forwards them) matches REGEX (extended).
set -u
regex=$1; shift
output=$("$@" 2>&1); status=$?
echo "$output"
if [ "$status" -ne 0 ]; then echo "FAIL: exit status $status, expected 0"; exit 1; fi
if ! grep -Eq -- "$regex" <<<"$output"; then echo "FAIL: output does not match: $regex"; exit 1; fi
echo "PASS: exit status 0, output matches"
