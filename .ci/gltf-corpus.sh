#!/usr/bin/env bash
# Write the glTF/GLB files that rtmesh's writing commands make (convert, pair -o,
# repair -o, inactive triangles, instances, the real glTFs) into the folder $1, for the
# glTF-Validator to check. Needs the release binary and RTMESH_DATA.
set -euo pipefail
out="$1"
rtmesh="${RTMESH:-target/release/rtmesh}"
data="${RTMESH_DATA:?set RTMESH_DATA}"
mkdir -p "$out"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\nf 1 1 2\nf 1 2 3\n' > "$out/degenerate.obj"
run() { "$rtmesh" "$@" > /dev/null; }
for ext in glb gltf; do
  run convert builtin:room "$out/room.$ext"
  run convert builtin:blob "$out/blob.$ext"
  run pair builtin:room -o "$out/room-paired.$ext" --no-prescan
  run repair builtin:room --split-scattered --merge-overlapping -o "$out/room-repaired.$ext" --size 0x0
  run repair builtin:cylinder --split-elongated --force-split -o "$out/cylinder-split.$ext" --size 0x0
  run repair "$out/degenerate.obj" --inactive --keep-duplicates -o "$out/inactive.$ext" --size 0x0 2> /dev/null
done
run convert "$data/2CylinderEngine.glb" "$out/engine.glb"
run pair "$data/2CylinderEngine.glb" -o "$out/engine-paired.glb"
run repair "$data/2CylinderEngine.glb" -o "$out/engine-repaired.glb" --size 0x0
run convert "$data/sponza_dabrovic.obj" "$out/sponza.gltf"
run pair "$data/spot.obj" -o "$out/spot-paired.glb"
for model in "$data"/animated/*.gl*; do
  name="$(basename "${model%.*}")"
  run convert "$model" "$out/animated-$name.glb" 2> /dev/null
  run pair "$model" -o "$out/animated-$name-paired.gltf" 2> /dev/null
  run repair "$model" --split-elongated --force-split -o "$out/animated-$name-split.glb" --size 0x0 2> /dev/null
done
morph=crates/rtmesh/tests/fixtures/morph-quad.gltf
run convert "$morph" "$out/morph.glb"
run pair "$morph" -o "$out/morph-paired.gltf"
run repair "$morph" --split-elongated --force-split -o "$out/morph-split.glb" --size 0x0
# KHR_mesh_quantization (as gltfpack writes it): written back in its integer types,
# positions as f32 where bisection or motion moved them off the integers.
quantized=crates/rtmesh/tests/fixtures/quantized-quad.gltf
run convert "$quantized" "$out/quantized.glb"
run optimize "$quantized" -o "$out/quantized-optimized.gltf" --size 0x0
run repair "$quantized" --split-elongated --force-split -o "$out/quantized-split.glb" --size 0x0
run animate "$quantized" --motion twist --frames 2 -o "$out/quantized-frames"
run convert "$quantized" "$out/quantized.obj"
run convert "$out/quantized.obj" "$out/quantized-from-obj.glb"
# A morph target in a sparse accessor over zeros, as Blender writes shape keys: written dense.
run convert crates/rtmesh/tests/fixtures/sparse-morph.gltf "$out/sparse-morph.glb"
run repair crates/rtmesh/tests/fixtures/sparse-morph.gltf --split-elongated --force-split -o "$out/sparse-morph-split.gltf" --size 0x0
run repair "$data/spot.obj" --split-elongated --force-split -o "$out/spot-split.glb" --size 0x0
run repair "$data/sponza_dabrovic.obj" --split-scattered --merge-overlapping -o "$out/sponza-regrouped.glb" --size 0x0 2> /dev/null
run repair "$data/2CylinderEngine.glb" --split-scattered --merge-overlapping -o "$out/engine-regrouped.gltf" --size 0x0
# An OBJ with an MTL library and PNG textures, as glTF: its colours and textures
# translated, the images copied beside the outputs (the validator loads them).
src="$(mktemp -d)"
mkdir -p "$src/tex"
python3 - "$src/tex" <<'PY'
import struct, sys, zlib
def png(path, rgba):
    rows = b''.join(b'\x00' + bytes(rgba) * 4 for _ in range(4))
    chunk = lambda t, d: struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d))
    head = struct.pack('>IIBBBBB', 4, 4, 8, 6, 0, 0, 0)
    open(path, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', head) + chunk(b'IDAT', zlib.compress(rows)) + chunk(b'IEND', b''))
png(sys.argv[1] + '/paint.png', [200, 100, 50, 255])
png(sys.argv[1] + '/normal.png', [128, 128, 255, 255])
PY
printf 'newmtl paint\nKd 1 0 0\nmap_Kd tex/paint.png\nnorm tex/normal.png\nnewmtl glass\nKd 0.2 0.4 0.6\nd 0.5\nKe 0.1 0 0\n' > "$src/textured.mtl"
printf 'mtllib textured.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\nusemtl paint\nf 1/1/1 2/2/1 3/3/1\nusemtl glass\nf 2/2/1 4/4/1 3/3/1\n' > "$src/textured.obj"
mkdir -p "$out/textured"
run convert "$src/textured.obj" "$out/textured/textured.gltf"
run convert "$src/textured.obj" "$out/textured/textured.glb"
run optimize "$src" -o "$out/textured/optimized" --format glb --size 0x0
# glTF to OBJ and back: the materials through an MTL library, the GLB's stored images
# extracted beside the OBJ and stored again in the GLB written from it.
mkdir -p "$out/textured/obj" "$out/cesium"
run convert "$out/textured/textured.glb" "$out/textured/obj/textured.obj"
run convert "$out/textured/obj/textured.obj" "$out/textured/obj/back.glb"
# A .gltf whose images are files, as one GLB.
run convert "$out/textured/textured.gltf" "$out/textured/from-gltf.glb"
run convert "$data/animated/CesiumMan.glb" "$out/cesium/cesium.obj" 2> /dev/null
run convert "$out/cesium/cesium.obj" "$out/cesium/back.glb"
# A MeshLab PLY (`comment TextureFile`, texture coordinates per corner, `texnumber`)
# as glTF and GLB, and through OBJ.
printf 'ply\nformat ascii 1.0\ncomment TextureFile tex/paint.png\ncomment TextureFile tex/normal.png\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nproperty int texnumber\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 6 0 0 1 0 1 1 0\n3 0 2 3 6 0.5 0.5 0.25 0.25 0 1 1\n' > "$src/meshlab.ply"
mkdir -p "$out/meshlab"
run convert "$src/meshlab.ply" "$out/meshlab/meshlab.gltf"
run convert "$src/meshlab.ply" "$out/meshlab/meshlab.glb"
run convert "$src/meshlab.ply" "$out/meshlab/meshlab.obj"
run convert "$out/meshlab/meshlab.obj" "$out/meshlab/from-obj.glb"
# Two scenes and a node in none: every node keeps placing its mesh.
python3 - "$src/scenes.gltf" <<'PY'
import base64, json, struct, sys
data = struct.pack('<18f', 0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 0, 0, 6, 0, 0, 5, 1, 0)
view = lambda i: {'buffer': 0, 'byteOffset': 36 * i, 'byteLength': 36}
accessor = lambda i, x: {'bufferView': i, 'componentType': 5126, 'count': 3, 'type': 'VEC3', 'min': [x, 0, 0], 'max': [x + 1, 1, 0]}
json.dump({'asset': {'version': '2.0'}, 'scene': 0, 'scenes': [{'nodes': [0]}, {'nodes': [1]}],
           'nodes': [{'mesh': 0}, {'mesh': 1}, {'mesh': 1}],
           'meshes': [{'primitives': [{'attributes': {'POSITION': 0}}]}, {'primitives': [{'attributes': {'POSITION': 1}}]}],
           'buffers': [{'byteLength': 72, 'uri': 'data:application/octet-stream;base64,' + base64.b64encode(data).decode()}],
           'bufferViews': [view(0), view(1)], 'accessors': [accessor(0, 0), accessor(1, 5)]}, open(sys.argv[1], 'w'))
PY
run convert "$src/scenes.gltf" "$out/scenes.glb"
run optimize "$src/scenes.gltf" -o "$out/scenes-optimized.gltf" --size 0x0
rm -rf "$src"
# `animate --motion gltf`: skinned frames baked into one geometry each, with the
# source's materials and textures (the .gltf frames store CesiumMan's image in .bin).
run animate "$data/animated/Fox.glb" --motion gltf:Run --frames 3 -o "$out/fox-run-frames"
run animate "$data/animated/CesiumMan.glb" --motion gltf --frames 2 -o "$out/cesium-frames" --format gltf
run animate "$data/animated/BrainStem.glb" --motion gltf --frames 2 -o "$out/brainstem-frames" --format gltf
# `strip`: TRIANGLE_STRIP primitives, joined by degenerate triangles.
run strip "$data/2CylinderEngine.glb" -o "$out/strips-engine.glb"
run strip "$data/animated/BCN_Epileptic.glb" -o "$out/strips-skinned.glb"
run strip builtin:room -o "$out/strips-room.gltf"
# `optimize`, the main job: every glTF/GLB of the library as itself, the OBJ scenes
# with materials as GLB, and the skinned models as .gltf.
run optimize "$data/2CylinderEngine.glb" "$data/animated" "$data/sponza_dabrovic.obj" "$data/spot.obj" "$data/conference.obj" -o "$out/optimized" --format glb --size 0x0 2> /dev/null
run optimize "$data/animated" builtin:room -o "$out/optimized-gltf" --format gltf --size 0x0 2> /dev/null
