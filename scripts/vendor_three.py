"""Vendor three.js (MIT) for the robot display's 3D head: only the files the page loads.

    python scripts/vendor_three.py [three-0.182.0.tgz]

Without an argument it runs ``npm pack three@0.182.0`` (the registry is the only network
it needs). The version is pinned: 0.182.0 ships the minified ES module builds
(``build/three.module.min.js`` importing ``build/three.core.min.js``); 0.187.0, npm's
``latest`` when this was written, ships only the unminified ones. The page's
import map maps ``three`` to the module build and ``three/addons/`` to the copied addons
(``GLTFLoader`` for a lab's own head, and the two utilities it imports), so every file is
served by this server: no CDN.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VERSION = "0.182.0"
VENDOR_DIR = ROOT / "chameleons" / "frontend" / "static" / "vendor" / "three"
KEEP = {
    "build/three.module.min.js": "build/three.module.min.js",
    "build/three.core.min.js": "build/three.core.min.js",
    "examples/jsm/loaders/GLTFLoader.js": "addons/loaders/GLTFLoader.js",
    "examples/jsm/utils/BufferGeometryUtils.js": "addons/utils/BufferGeometryUtils.js",
    "examples/jsm/utils/SkeletonUtils.js": "addons/utils/SkeletonUtils.js",
    "LICENSE": "LICENSE.txt",
}
README = f"""three.js {VERSION} (MIT, Copyright 2010-2025 three.js authors), from the npm registry
(npm pack three@{VERSION}), written here by scripts/vendor_three.py. Pinned: a recent
release that ships the minified ES module builds (0.187.0 ships only unminified ones).
Only the files the robot display's 3D head loads: build/three.module.min.js and
build/three.core.min.js, and from examples/jsm the
GLTFLoader (a lab's own GLB/VRM head) with the two utilities it imports, under addons/.
Vendored so the booth works offline (no CDN); see LICENSE.txt.
"""


def main(argv: list[str]) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        if argv:
            tgz = Path(argv[0]).resolve()
        else:
            subprocess.run(["npm", "pack", f"three@{VERSION}"], cwd=tmp, check=True)
            tgz = next(Path(tmp).glob("*.tgz"))
        with tarfile.open(tgz) as archive:
            archive.extractall(tmp, filter="data")
        package = Path(tmp) / "package"
        if VENDOR_DIR.exists():
            shutil.rmtree(VENDOR_DIR)
        for source, target in KEEP.items():
            (VENDOR_DIR / target).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(package / source, VENDOR_DIR / target)
    (VENDOR_DIR / "README.txt").write_text(README, "utf-8")
    print("vendored three.js", VERSION, "to", VENDOR_DIR)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
