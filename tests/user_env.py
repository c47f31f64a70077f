"""The environment a user's shell has after `source scripts/env.sh`, for the commands tests run as a user does."""
from __future__ import annotations

import subprocess
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@lru_cache(maxsize=1)
def _sourced() -> tuple[tuple[str, str], ...]:
    out = subprocess.run(["bash", "-c", f"source {ROOT}/scripts/env.sh >/dev/null && env -0"],
                         check=True, capture_output=True, cwd=ROOT).stdout.decode()
    return tuple(tuple(item.split("=", 1)) for item in out.split("\0") if "=" in item)


def workspace_env(domain: int | None = None) -> dict[str, str]:
    """A fresh copy of that environment, with unbuffered output (logs are read while a node runs), one
    BLAS thread (the tests share 2 cores) and, for commands that may touch DDS, the test's ROS_DOMAIN_ID."""
    env = dict(_sourced())
    env.update(PYTHONUNBUFFERED="1", RCUTILS_LOGGING_BUFFERED_STREAM="0", OMP_NUM_THREADS="1")
    if domain is not None:
        env["ROS_DOMAIN_ID"] = str(domain)
    return env
