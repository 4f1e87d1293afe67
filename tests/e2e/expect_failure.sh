#!/usr/bin/env bash
# expect_failure.sh REGEX RESULT_FILE COMMAND...: passes when COMMAND exits non-zero, its
# output matches REGEX (extended), and neither RESULT_FILE nor RESULT_FILE.partial exists.
set -u
regex=$1; result=$2; shift 2
rm -f "$result" "$result.partial"
output=$("$@" 2>&1); status=$?
echo "$output"
if [ "$status" -eq 0 ]; then echo "FAIL: exit status 0, expected a failure"; exit 1; fi
if ! grep -Eq -- "$regex" <<<"$output"; then echo "FAIL: output does not match: $regex"; exit 1; fi
if [ -e "$result" ] || [ -e "$result.partial" ]; then echo "FAIL: a result file was left: $result"; exit 1; fi
echo "PASS: exit status $status, message matches"
