"""What a failed subprocess said: the message of the tests' assertions on demo runs."""
from __future__ import annotations

import subprocess

#: characters kept from the end of each stream
TAIL = 4000


def report(proc: subprocess.CompletedProcess) -> str:
    """Exit code, the command, and the tails of stdout and stderr of a finished subprocess (an
    assertion on the exit code alone hid a run's last lines when it failed)."""
    command = " ".join(str(a) for a in proc.args) if isinstance(proc.args, (list, tuple)) else str(proc.args)
    return (f"exit code {proc.returncode} of: {command}\n"
            f"--- stdout (last {TAIL} characters)\n{(proc.stdout or '')[-TAIL:]}\n"
            f"--- stderr (last {TAIL} characters)\n{(proc.stderr or '')[-TAIL:]}")
