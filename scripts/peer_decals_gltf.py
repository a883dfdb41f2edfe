#!/usr/bin/env python3
"""Writes PEERS.md's "decals and lights" scene as a glTF, so that the sandbox can run the scene
Bevy was measured in (issue: decals at a million, item 5):

    python3 scripts/peer_decals_gltf.py OUT.gltf [--floor-roughness R]
    sandbox --scene OUT.gltf --decals N --no-shadows --pipeline forward_plus ...

With --floor-roughness the ground is a metal of that roughness (0.02: a mirror), the scene of
the reflections issue: a mirror floor, 28 lights and 1,000 decals.

A 40 m ground quad, 60 unit boxes (a fixed pseudo-random layout over the middle 30 m), 28 point
lights of 8 m range 1.5 m above the ground on a 7 x 4 grid over the 30 m square, a sun, and the
camera at (0, 1.7, 18) looking at the origin with a 45 degree vertical field of view. `--decals
N` then scatters the decals uniformly by area over every surface (0.3-1.2 m, box depth 0.3 x
size, along the surface normal), as PEERS.md describes.
"""
import base64
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from boxes_gltf import box  # noqa: E402  (the same unit box)


def quad_and_box():
    """A 1 m ground quad (facing +y) and the unit box of boxes_gltf.py, as one blob of positions,
    normals and indices (the quad's first)."""
    positions = [[x, 0.0, z] for x, z in ((-0.5, -0.5), (-0.5, 0.5), (0.5, 0.5), (0.5, -0.5))]
    normals = [[0.0, 1.0, 0.0]] * 4
    indices = [0, 1, 2, 0, 2, 3]
    box_positions, box_normals, box_indices = box()
    indices += [len(positions) + i for i in box_indices]
    return positions + box_positions, normals + box_normals, indices, 6


def rng(seed):
    """SplitMix64, as the sandbox's scatter uses, so the layout is the same on every machine."""
    state = seed
    while True:
        state = (state + 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
        yield ((z ^ (z >> 31)) >> 40) / float(1 << 24)


def main():
    out = sys.argv[1]
    floor_roughness = float(sys.argv[sys.argv.index("--floor-roughness") + 1]) if "--floor-roughness" in sys.argv else None
    positions, normals, indices, quad_indices = quad_and_box()
    blob = b"".join(struct.pack("<3f", *p) for p in positions)
    blob += b"".join(struct.pack("<3f", *p) for p in normals)
    blob += b"".join(struct.pack("<I", i) for i in indices)
    pos_len, idx_off = 12 * len(positions), 24 * len(positions)
    r = rng(7)
    nodes = [{"name": "ground", "mesh": 0, "scale": [40.0, 1.0, 40.0]}]
    for i in range(60):
        x, z, yaw = next(r) * 30.0 - 15.0, next(r) * 30.0 - 15.0, next(r) * math.tau
        nodes.append({
            "name": f"box{i}",
            "mesh": 1,
            "translation": [x, 0.5, z],
            "rotation": [0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)],
        })
    lights = []
    for i in range(28):
        col, row = i % 7, i // 7
        lights.append({"type": "point", "color": [1.0, 0.85 + 0.05 * (i % 3), 0.7 + 0.1 * (i % 2)], "intensity": 8.0, "range": 8.0})
        nodes.append({"name": f"light{i}", "translation": [-15.0 + col * 5.0, 1.5, -15.0 + row * 10.0], "extensions": {"KHR_lights_punctual": {"light": i}}})
    lights.append({"type": "directional", "color": [1.0, 0.96, 0.9], "intensity": 2.0})
    # The sun looks down (-z of the node) tilted: a rotation of -60 degrees about x, then 30 about y.
    pitch, yaw = -math.radians(60.0), math.radians(30.0)
    qy = [0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)]
    qx = [math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]
    sun = [
        qy[3] * qx[0] + qy[0] * qx[3] + qy[1] * qx[2] - qy[2] * qx[1],
        qy[3] * qx[1] - qy[0] * qx[2] + qy[1] * qx[3] + qy[2] * qx[0],
        qy[3] * qx[2] + qy[0] * qx[1] - qy[1] * qx[0] + qy[2] * qx[3],
        qy[3] * qx[3] - qy[0] * qx[0] - qy[1] * qx[1] - qy[2] * qx[2],
    ]
    nodes.append({"name": "sun", "rotation": sun, "extensions": {"KHR_lights_punctual": {"light": 28}}})
    # The camera at (0, 1.7, 18) looking at the origin: pitched down by atan(1.7 / 18).
    down = -math.atan2(1.7, 18.0)
    nodes.append({"name": "camera", "camera": 0, "translation": [0.0, 1.7, 18.0], "rotation": [math.sin(down / 2), 0.0, 0.0, math.cos(down / 2)]})
    gltf = {
        "asset": {"version": "2.0", "generator": "scripts/peer_decals_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": lights}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(45.0), "znear": 0.1}}],
        "meshes": [
            {"name": "ground", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]},
            {"name": "box", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 3, "material": 1}]},
        ],
        "materials": [
            {"name": "ground", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.85}}
            if floor_roughness is None
            else {"name": "mirror", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1.0], "metallicFactor": 1.0, "roughnessFactor": floor_roughness}},
            {"name": "box", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.55, 0.4, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.6}},
        ],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": idx_off, "byteLength": 4 * quad_indices},
            {"buffer": 0, "byteOffset": idx_off + 4 * quad_indices, "byteLength": 4 * (len(indices) - quad_indices)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": [-0.5] * 3, "max": [0.5] * 3},
            {"bufferView": 1, "componentType": 5126, "count": len(normals), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": quad_indices, "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5125, "count": len(indices) - quad_indices, "type": "SCALAR"},
        ],
    }
    with open(out, "w") as f:
        json.dump(gltf, f)


if __name__ == "__main__":
    main()
