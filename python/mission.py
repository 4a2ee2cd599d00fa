#!/usr/bin/env python3
"""The whole survey in one command (see `python python/mission.py --help`, docs/survey.md).

Works with whatever `python` comes first on PATH: unless it already is the project's
.venv interpreter, it re-executes itself under .venv/bin/python (made by `make` /
tools/setup.sh), where numpy, Dask and the mound package are installed.
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VENV = ROOT / ".venv"
VENV_PYTHON = VENV / "bin" / "python"

if Path(sys.prefix).resolve() != VENV.resolve():
    if not VENV_PYTHON.exists():
        sys.stderr.write(f"mission.py: {VENV_PYTHON} not found: run `make` first (it runs "
                         "tools/setup.sh and builds the tools)\n")
        sys.exit(2)
    os.execv(str(VENV_PYTHON), [str(VENV_PYTHON), str(Path(__file__).resolve()),
                                *sys.argv[1:]])

sys.path.insert(0, str(ROOT / "python"))
from mound.survey.driver import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
