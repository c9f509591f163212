"""Run the load benchmark: ``python -m benchmarks.api_load`` or ``python benchmarks/api_load``."""

from __future__ import annotations

import sys
from pathlib import Path

if not __package__:  # run as a directory: import the package from the repository root instead
    sys.path[0] = str(Path(__file__).resolve().parents[2])

from benchmarks.api_load.cli import main  # noqa: E402

if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        print("\ninterrupted: servers stopped, benchmark databases dropped", file=sys.stderr)
        sys.exit(130)
