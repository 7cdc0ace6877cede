"""Vendor MediaPipe's face mesh package and extract its canonical face geometry.

    python scripts/vendor_face_mesh.py [mediapipe-face_mesh-0.4.1633559619.tgz]

Without an argument it runs ``npm pack @mediapipe/face_mesh@0.4.1633559619`` (the registry
is the only network it needs). The version is pinned: 0.4.1657299874 (npm ``latest``)
aborts on load (google/mediapipe issue 3504). The package ships its models inside
``face_mesh_solution_packed_assets.data`` (face detection, 468 and 478 point landmarks,
and the face-geometry metadata); their byte ranges are written in
``face_mesh_solution_packed_assets_loader.js``. This script copies the package to
``chameleons/frontend/static/vendor/mediapipe-face-mesh/`` (served by the server to the
capture page; no CDN) and writes ``canonical_face_mesh.json`` beside it: the canonical
mesh (468 vertices in cm, UVs, 898 triangles) and the weighted Procrustes landmark basis,
decoded from ``geometry_pipeline_metadata_landmarks.binarypb`` (the message
``mediapipe.face_geometry.GeometryPipelineMetadata``, mediapipe/modules/face_geometry/
protos/geometry_pipeline_metadata.proto). Both the webcam tracker and the 3D robot head
read that one JSON file.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from chameleons.facemesh.assets import (  # noqa: E402
    VENDOR_DIR,
    VERSION,
    canonical_mesh_json,
    packed_files,
)

KEEP = (
    "face_mesh.js", "face_mesh.binarypb", "face_mesh_solution_packed_assets.data",
    "face_mesh_solution_packed_assets_loader.js", "face_mesh_solution_simd_wasm_bin.js",
    "face_mesh_solution_simd_wasm_bin.wasm", "face_mesh_solution_wasm_bin.js",
    "face_mesh_solution_wasm_bin.wasm", "package.json", "index.d.ts",
)  # fmt: skip


def main(argv: list[str]) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        if argv:
            tgz = Path(argv[0]).resolve()
        else:
            subprocess.run(["npm", "pack", f"@mediapipe/face_mesh@{VERSION}"], cwd=tmp,
                           check=True)  # fmt: skip
            tgz = next(Path(tmp).glob("*.tgz"))
        with tarfile.open(tgz) as archive:
            archive.extractall(tmp, filter="data")
        package = Path(tmp) / "package"
        VENDOR_DIR.mkdir(parents=True, exist_ok=True)
        for name in KEEP:
            shutil.copyfile(package / name, VENDOR_DIR / name)
    licence = Path("/usr/share/common-licenses/Apache-2.0")
    if licence.exists():
        shutil.copyfile(licence, VENDOR_DIR / "LICENSE.txt")
    (VENDOR_DIR / "canonical_face_mesh.json").write_text(canonical_mesh_json(), "utf-8")
    print("vendored", VENDOR_DIR, "models:", ", ".join(sorted(packed_files())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
