"""Write the hostile-input corpus into FOLDER/asset (a canary beside it in FOLDER).

File names say what rtmesh must do with each: `refuse-*` fail with an error that names
the file and the refused reference; `error-*` fail with an error that names the file;
`ok-*` succeed; `any-*` succeed or fail cleanly (empty files); `amp-*` (amplification) have
expectations by subcommand in `.ci/hostile.sh`. Every class of failure in
issue 36, and something for every reader."""
import base64, json, math, os, struct, sys

if len(sys.argv) != 2 or sys.argv[1].startswith("-"):
    sys.exit("usage: hostile_corpus.py FOLDER (the corpus goes to FOLDER/asset)")
root = sys.argv[1]
asset = os.path.join(root, "asset")
os.makedirs(asset, exist_ok=True)
CANARY = 12345.5  # a position no crafted file holds: seeing it means the canary was read


def write(name, data):
    with open(os.path.join(asset, name), "wb" if isinstance(data, bytes) else "w") as f:
        f.write(data)


with open(os.path.join(root, "canary.bin"), "wb") as f:
    f.write(struct.pack("<9f", *[CANARY] * 9))
with open(os.path.join(root, "canary.mtl"), "w") as f:
    f.write("newmtl stolen\nKd 1 0 0\n")

triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
write("refuse-mtllib-absolute.obj", "mtllib /etc/passwd\n" + triangle)
write("refuse-mtllib-climb.obj", "mtllib ../canary.mtl\n" + triangle)
write("refuse-mtllib-device.obj", "mtllib /dev/zero\n" + triangle)
write("error-obj-bad-index.obj", "g part\n" + triangle + "f 1 2 9\n" + "v 2 2 2\n" * 30)
write("ok-obj-lines-and-points.obj", triangle + "l 1 2 3\np 1 2\n")
write("ok-obj-nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
write("any-empty.obj", "")
# MTL colours: one number is a grey (tobj panicked on fewer than three), two an error.
write("grey.mtl", "newmtl grey\nKd 0.5\nKe 0\nmap_Kd ../canary.mtl\n")
write("ok-obj-mtl-grey.obj", "mtllib grey.mtl\nusemtl grey\n" + triangle)
write("two.mtl", "newmtl two\nKd 1 0\n")
write("error-obj-mtl-two-numbers.obj", "mtllib two.mtl\nusemtl two\n" + triangle)


def gltf(buffer_uri, nodes=None, roots=None, view_extra=None):
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": buffer_uri, "byteLength": 36}],
        "bufferViews": [dict({"buffer": 0, "byteLength": 36}, **(view_extra or {}))],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": nodes or [{"mesh": 0}],
        "scenes": [{"nodes": roots or [0]}],
        "scene": 0,
    }
    return json.dumps(doc)


corners = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
write("ok-bare.bin", corners)
write("ok-bare.gltf", gltf("ok-bare.bin"))
# Image URIs are never read, only copied beside outputs elsewhere, by the same rule.
with_images = json.loads(gltf("ok-bare.bin"))
with_images["images"] = [{"uri": u} for u in ["../canary.bin", "%2e%2e/canary.bin", "/etc/passwd", "/dev/zero", "missing.png", "ok-bare.bin"]]
write("ok-gltf-image-uris.gltf", json.dumps(with_images))
# The same images as materials' textures, with a data: URI of no image and a buffer view
# as an image: written as OBJ, each becomes a map of the MTL library beside it (stored
# ones extracted), and the same rule keeps the canary out of every copy.
with_images["images"] += [{"uri": "data:image/png;base64,AAAA"}, {"bufferView": 0, "mimeType": "image/png"}]
with_images["textures"] = [{"source": i} for i in range(len(with_images["images"]))]
with_images["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": i}},
                             "normalTexture": {"index": i, "scale": 2}}
                            for i in range(len(with_images["images"]))]
with_images["meshes"][0]["primitives"][0]["material"] = 0
write("ok-gltf-material-images.gltf", json.dumps(with_images))
write("refuse-buffer-climb.gltf", gltf("../canary.bin"))
write("refuse-buffer-escaped.gltf", gltf("%2e%2e/canary.bin"))
write("refuse-buffer-absolute.gltf", gltf(os.path.join(root, "canary.bin")))
write("refuse-buffer-device.gltf", gltf("/dev/zero"))
os.symlink(os.path.join(root, "canary.bin"), os.path.join(asset, "link.bin"))
write("refuse-buffer-link.gltf", gltf("link.bin"))
write("error-stride.gltf", gltf("ok-bare.bin", view_extra={"byteStride": 8}))
write("error-node-twice.gltf", gltf("ok-bare.bin", nodes=[{"mesh": 0, "children": [0, 0]}]))
write("error-node-self.gltf", gltf("ok-bare.bin", nodes=[{"mesh": 0, "children": [0]}]))
chain = [{"translation": [1, 0, 0], "children": [i + 1]} for i in range(9999)]
chain.append({"translation": [1, 0, 0], "mesh": 0})
write("ok-node-chain.gltf", gltf("ok-bare.bin", nodes=chain))
glb_json = gltf("data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA").encode()
glb_json += b" " * (-len(glb_json) % 4)
glb = b"glTF" + struct.pack("<II", 2, 12 + 8 + len(glb_json)) + struct.pack("<I4s", len(glb_json), b"JSON") + glb_json
write("ok-inline.glb", glb)
write("error-glb-lying-length.glb", glb[:8] + struct.pack("<I", 10_000_000) + glb[12:])
write("any-empty.gltf", "")

ply_header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n{}element face 1\nproperty list uchar int vertex_indices\nend_header\n"
write("error-ply-no-z.ply", ply_header.format("") + "0 0\n1 0\n0 1\n3 0 1 2\n")
write("error-ply-absurd-count.ply", ply_header.replace("vertex 3", "vertex 4000000000").format("property float z\n") + "0 0 0\n")
strips = [0, 1, 2, 3, -1, 2, 3, 4, 4, 5]
write("ok-ply-tristrips.ply",
      "ply\nformat binary_little_endian 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
      "element tristrips 1\nproperty list int int vertex_indices\nend_header\n".encode()
      + struct.pack("<18f", 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0, 1, 2, 0)
      + struct.pack("<i", len(strips)) + struct.pack(f"<{len(strips)}i", *strips))
write("any-empty.ply", "")
# Face properties are kept per triangle; an edge element and a list per face are named
# as not read.
write("ok-ply-face-properties.ply",
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty int label\n"
      "property list uchar int neighbours\nelement edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 7 0\n3 0 2 3 0 -1 2 1 3\n0 2\n")
# MeshLab's texture comment naming the canary: no output may hold its bytes.
write("ok-ply-texture-climb.ply",
      "ply\nformat ascii 1.0\ncomment TextureFile ../canary.bin\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0 1 0 0 1\n")
write("error-ply-texcoord-count.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 3 0 0 1\n")
# A polygon's properties are repeated on each triangle of its fan: three faces of 3,000
# corners and 3,000 properties (66 kB) would ask for 27 M values.
n = 3000
write("error-ply-fan-properties.ply",
      (f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
       f"element face 3\nproperty list uint uint vertex_indices\n"
       + "".join(f"property uchar p{i}\n" for i in range(n)) + "end_header\n").encode()
      + b"".join(struct.pack("<3f", i, i % 7, i % 3) for i in range(n))
      + (struct.pack("<I", n) + struct.pack(f"<{n}I", *range(n)) + bytes(n)) * 3)

stl_facet = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0)
write("ok-stl-binary.stl", b" " * 80 + struct.pack("<I", 1) + stl_facet)
write("error-stl-lying-count.stl", b" " * 80 + struct.pack("<I", 100_000_000) + stl_facet)
write("ok-stl-ascii.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n")
write("error-stl-ascii-four-vertices.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nvertex 1 1 0\nendloop\nendfacet\nendsolid s\n")
write("any-empty.stl", "")

# Pathological topology: a million copies of one triangle, a book of 100,000 pages on
# one edge, a fan of 200,000 triangles.
with open(os.path.join(asset, "ok-million-copies.obj"), "w") as f:
    f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * 1_000_000)
with open(os.path.join(asset, "ok-book.obj"), "w") as f:
    n = 100_000
    f.write("v 0 0 0\nv 0 0 1\n")
    f.write("".join(f"v {math.cos(2 * math.pi * k / n)} {math.sin(2 * math.pi * k / n)} 0.5\n" for k in range(n)))
    f.write("".join(f"f 1 2 {k + 3}\n" for k in range(n)))
with open(os.path.join(asset, "ok-fan.obj"), "w") as f:
    n = 200_000
    f.write("v 0 0 0\n")
    f.write("".join(f"v {math.cos(2 * math.pi * k / n)} {math.sin(2 * math.pi * k / n)} 0\n" for k in range(n)))
    f.write("".join(f"f 1 {k + 2} {(k + 1) % n + 2}\n" for k in range(n)))

# Amplification: a small file that names one accessor from thousands of places.
def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


def scene_doc(data, views, accessors, meshes, nodes, **extra):
    doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": data_uri(data), "byteLength": len(data)}],
           "bufferViews": views, "accessors": accessors, "meshes": meshes, "nodes": nodes,
           "scenes": [{"nodes": [0]}], "scene": 0}
    doc.update(extra)
    return json.dumps(doc)


n = 30_000  # 10,000 triangles without indices
soup = b"".join(struct.pack("<3f", k * 1e-3 + (k % 3 == 1), float(k % 3 == 2), 0) for k in range(n))
soup_accessor = {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
                 "min": [0, 0, 0], "max": [31, 1, 0]}
# 2,000 primitives on one accessor: 20 M triangles out of 0.5 MB.
write("error-amp-primitives.gltf", scene_doc(
    soup, [{"buffer": 0, "byteLength": len(soup)}], [soup_accessor],
    [{"primitives": [{"attributes": {"POSITION": 0}}] * 2000}], [{"mesh": 0}]))
# 10,000 placements of one 10,000-triangle mesh: 100 M triangles once flattened
# (tracing keeps instances; the one-level writers and strips refuse).
write("amp-instances.gltf", scene_doc(
    soup, [{"buffer": 0, "byteLength": len(soup)}], [soup_accessor],
    [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    [{"children": list(range(1, 10_001))}] + [{"mesh": 0, "translation": [k, 0, 0]} for k in range(10_000)]))
# 4,000 animation channels on one pair of 100,000-key accessors: 6.4 GB of keys.
keys = 100_000
times = struct.pack(f"<{keys}f", *[k / 30 for k in range(keys)])
moves = bytes(12 * keys)
animated = corners + times + moves
write("amp-channels.gltf", scene_doc(
    animated,
    [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": len(times)},
     {"buffer": 0, "byteOffset": 36 + len(times), "byteLength": len(moves)}],
    [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
     {"bufferView": 1, "componentType": 5126, "count": keys, "type": "SCALAR", "min": [0], "max": [(keys - 1) / 30]},
     {"bufferView": 2, "componentType": 5126, "count": keys, "type": "VEC3"}],
    [{"primitives": [{"attributes": {"POSITION": 0}}]}], [{"mesh": 0}],
    animations=[{"samplers": [{"input": 1, "output": 2}],
                 "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}] * 4000}]))
# Sparse accessors (as Blender writes shape keys): substitutions past the elements, more
# substitutions than elements, and zeros for 100 M vertices out of a few bytes (refused
# by the read budget, not allocated).
def sparse_doc(count, sparse_count, index):
    data = corners + struct.pack("<2H", index, 0) + struct.pack("<3f", 0, 0, 0.5)
    views = [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 4},
             {"buffer": 0, "byteOffset": 40, "byteLength": 12}]
    accessors = [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                 {"componentType": 5126, "count": count, "type": "VEC3",
                  "sparse": {"count": sparse_count, "indices": {"bufferView": 1, "componentType": 5123},
                             "values": {"bufferView": 2}}}]
    return scene_doc(data, views, accessors,
                     [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 1}]}]}], [{"mesh": 0}])
write("ok-sparse-morph.gltf", sparse_doc(3, 1, 1))
write("error-sparse-index-past.gltf", sparse_doc(3, 1, 7))
write("error-sparse-count.gltf", sparse_doc(3, 4_000_000_000, 1))
write("error-sparse-zeros-amplified.gltf", sparse_doc(100_000_000, 1, 1))
amplified = json.loads(sparse_doc(100_000_000, 1, 1))
amplified["accessors"][1].update({"min": [0, 0, 0], "max": [0, 0, 0.5]})
amplified["meshes"][0]["primitives"][0] = {"attributes": {"POSITION": 1}}
write("error-sparse-positions-amplified.gltf", json.dumps(amplified))
# EXT_meshopt_compression claiming 4e9 elements of 256 bytes from 16 bytes (past the
# decode cap), and claiming data outside its buffer.
def meshopt_doc(count, offset):
    doc = json.loads(scene_doc(corners, [{"buffer": 1, "byteLength": 36, "byteStride": 12,
        "extensions": {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": offset, "byteLength": 16,
                                                  "byteStride": 256, "count": count, "mode": "ATTRIBUTES"}}}],
        [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
        [{"primitives": [{"attributes": {"POSITION": 0}}]}], [{"mesh": 0}],
        extensionsUsed=["EXT_meshopt_compression"], extensionsRequired=["EXT_meshopt_compression"]))
    doc["buffers"].append({"byteLength": 36, "extensions": {"EXT_meshopt_compression": {"fallback": True}}})
    return json.dumps(doc)
write("error-meshopt-count.gltf", meshopt_doc(4_000_000_000, 0))
write("error-meshopt-gigabyte.gltf", meshopt_doc(4_000_000, 0))
write("error-meshopt-outside.gltf", meshopt_doc(3, 1_000_000))
# Integer positions without KHR_mesh_quantization, which alone allows them.
write("error-gltf-integer-positions.gltf", scene_doc(
    struct.pack("<9h3h", 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0),
    [{"buffer": 0, "byteLength": 24}],
    [{"bufferView": 0, "componentType": 5122, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
    [{"primitives": [{"attributes": {"POSITION": 0}}]}], [{"mesh": 0}]))

# One 2 MB material library (100,000 materials) named 2,000 times, and by 40 spellings
# of its path (92 MB: past the 16 MiB that an OBJ's libraries may hold together).
write("library.mtl", "".join(f"newmtl m{k}\nKd 1 0 0\n" for k in range(100_000)))
write("ok-obj-mtllib-repeated.obj", "mtllib library.mtl\n" * 2000 + "usemtl m5\n" + triangle)
write("amp-obj-mtllib-respelled.obj", "".join(f"mtllib {'./' * k}library.mtl\n" for k in range(40)) + triangle)
