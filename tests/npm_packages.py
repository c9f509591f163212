"""npm packages the OPC UA tests install at test time (nothing of theirs is in the repository).

``node-opcua-nodesets`` (MIT) holds the OPC Foundation's companion-specification nodesets
(``Opc.Ua.CNC.NodeSet.xml``, ``Opc.Ua.MachineTool.NodeSet2.xml`` and what they need);
``node-opcua`` (MIT) is a second, independent OPC UA server implementation. Both are installed
with ``npm install`` from the npm registry into one folder (``RCB_TEST_NPM_DIR``, default
``$TMPDIR/rcb-test-npm``), once: later runs find them there. A test that needs them skips,
saying why, when node or npm is missing or the registry cannot be reached.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

#: Pinned: the versions the tests were written against.
PACKAGES = ("node-opcua@2.182.2", "node-opcua-nodesets@2.182.0")
FOLDER_VARIABLE = "RCB_TEST_NPM_DIR"


def npm_folder() -> Path:
    """The folder whose ``node_modules`` holds :data:`PACKAGES` (installed now if need be)."""
    folder = Path(os.environ.get(FOLDER_VARIABLE) or Path(tempfile.gettempdir()) / "rcb-test-npm")
    for tool in ("node", "npm"):
        if shutil.which(tool) is None:
            pytest.skip(f"{tool} is not installed: the OPC UA nodeset tests need node and npm")
    folder.mkdir(parents=True, exist_ok=True)
    done = folder / f"installed-{'+'.join(PACKAGES)}"
    with (folder / "install.lock").open("w") as lock:  # one install across xdist workers
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            try:
                answer = subprocess.run(
                    ["npm", "install", "--no-audit", "--no-fund", "--no-save", *PACKAGES],
                    cwd=folder,
                    capture_output=True,
                    text=True,
                    timeout=600,
                )
            except subprocess.TimeoutExpired:
                pytest.skip(f"npm install {' '.join(PACKAGES)} took over 600 s")
            if answer.returncode != 0:
                last = (answer.stderr.strip().splitlines() or ["no output"])[-1]
                why = f"failed (is the registry reachable?): {last}"
                pytest.skip(f"npm install {' '.join(PACKAGES)} {why}")
            done.touch()
    return folder


def nodeset_folder() -> Path:
    """The folder of the OPC Foundation nodesets shipped in ``node-opcua-nodesets``."""
    return npm_folder() / "node_modules" / "node-opcua-nodesets" / "nodesets"
