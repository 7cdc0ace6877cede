"""MediaPipe's face mesh, vendored: its models and its canonical face geometry.

One copy on disk serves the browser (the capture page loads the npm package from
``/static/vendor/mediapipe-face-mesh/``), the Python tracker (which reads the same
``.tflite`` models out of the package's packed assets) and the 3D robot head (built from
the canonical mesh in ``canonical_face_mesh.json``).
"""
