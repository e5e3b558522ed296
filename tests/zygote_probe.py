"""A child for tests/test_zygote.py: says what it was started with, then exits as told."""

import json
import os
import signal
import sys
import time
from pathlib import Path

if __name__ == "__main__":
    if sys.argv[1] == "wait":  # before it says anything: the test signals it once it has spoken
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(7))
    print(
        json.dumps(
            {
                "argv": sys.argv[1:],
                "cwd": os.getcwd(),
                "probe_env": os.environ.get("ZYGOTE_PROBE"),
                "leader": os.getpgid(0) == os.getpid(),
                "stdin_closed": sys.stdin.read() == "",
                "comm": Path("/proc/self/comm").read_text().strip() if Path("/proc").is_dir() else None,
            }
        ),
        flush=True,
    )
    print("to stderr", file=sys.stderr, flush=True)
    if sys.argv[1] == "wait":
        time.sleep(60)
    if sys.argv[1] == "silent":  # its output closed, it runs on
        os.close(1)
        os.close(2)
        time.sleep(60)
    if sys.argv[1] == "interrupted":
        raise KeyboardInterrupt
    sys.exit(int(sys.argv[1]))
