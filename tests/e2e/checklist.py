"""The checks of an end-to-end test script: each printed as ok or FAILED, the failures kept for
the script's exit status."""

failures = []


def check(condition, message):
    print(("ok:     " if condition else "FAILED: ") + message, flush=True)
    if not condition:
        failures.append(message)
