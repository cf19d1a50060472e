# SPDX-License-Identifier: Apache-2.0
"""Seeds for fuzz_mesh_assimp: the scenes of tests/make_scenes.py (GLB, glTF
with the buffer embedded as a data: URI, 3MF), each prefixed with the byte
that picks its extension (0 .glb, 1 .gltf, 2 .3mf, 3 .fbx). With FBX_DIR,
also the FBX files test_assimp exports from scene.glb with Assimp
(scene_binary.fbx, scene_ascii.fbx in its in/ directory: Python cannot
write FBX).

usage: python3 tests/fuzz/make_assimp_seeds.py tests/fuzz/seeds_mesh_assimp [FBX_DIR]
  e.g. FBX_DIR = build/test-tmp/assimp/in after running test_assimp
"""
import base64
import json
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import make_scenes  # noqa: E402

out = sys.argv[1]
os.makedirs(out, exist_ok=True)
with tempfile.TemporaryDirectory() as d:
    make_scenes.write_glb(d)
    make_scenes.write_3mf(d)
    doc, blob = make_scenes.gltf_parts()
    doc["buffers"] = [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                       "byteLength": len(blob)}]
    seeds = {"scene.glb": (0, open(os.path.join(d, "scene.glb"), "rb").read()),
             "scene_embedded.gltf": (1, json.dumps(doc).encode()),
             "scene.3mf": (2, open(os.path.join(d, "scene.3mf"), "rb").read())}
for name, (k, data) in seeds.items():
    with open(os.path.join(out, name), "wb") as f:
        f.write(bytes([k]) + data)
if len(sys.argv) > 2:
    for name in ("scene_binary.fbx", "scene_ascii.fbx"):
        with open(os.path.join(sys.argv[2], name), "rb") as f:
            data = f.read()
        with open(os.path.join(out, name), "wb") as f:
            f.write(bytes([3]) + data)
