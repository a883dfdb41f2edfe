#!/usr/bin/env python3
"""Writes the scene of the GPU-driven-scene issue's first table: a glTF of N boxes (one 1 m box
mesh, N nodes on a square grid 1.5 m apart, one grey material), with no camera or light (the
sandbox frames the scene and adds both).

    python3 scripts/boxes_gltf.py N OUT.gltf
"""
import base64
import json
import math
import struct
import sys


def box():
    positions, normals, indices = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            base = len(positions)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = 0.5 * sign
                p[u] = 0.5 * a
                p[v] = 0.5 * b
                positions.append(p)
                normals.append(n)
            quad = [0, 1, 2, 0, 2, 3] if sign > 0 else [0, 2, 1, 0, 3, 2]
            indices += [base + i for i in quad]
    return positions, normals, indices


def main():
    n, out = int(sys.argv[1]), sys.argv[2]
    positions, normals, indices = box()
    blob = b"".join(struct.pack("<3f", *p) for p in positions)
    blob += b"".join(struct.pack("<3f", *p) for p in normals)
    blob += b"".join(struct.pack("<I", i) for i in indices)
    pos_len, idx_off = 12 * len(positions), 24 * len(positions)
    side = math.ceil(math.sqrt(n))
    nodes = [{"mesh": 0, "translation": [(i % side - side / 2) * 1.5, 0.5, (i // side - side / 2) * 1.5]} for i in range(n)]
    gltf = {
        "asset": {"version": "2.0", "generator": "scripts/boxes_gltf.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(n))}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": idx_off, "byteLength": 4 * len(indices)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": [-0.5] * 3, "max": [0.5] * 3},
            {"bufferView": 1, "componentType": 5126, "count": len(normals), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": len(indices), "type": "SCALAR"},
        ],
    }
    with open(out, "w") as f:
        json.dump(gltf, f)


if __name__ == "__main__":
    main()
