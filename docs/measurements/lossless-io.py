"""Keeping every attribute against keeping positions only, on the same input files.

Prepares in the current folder dragon_normals.ply (dragon_vrip.ply as binary PLY with
area-weighted vertex normals; needs numpy) and sponza_uv.obj (sponza_dabrovic.obj), then
alternates OLD (a binary from before the lossless I/O issue) and NEW on each case and
prints medians. Usage: OLD=... NEW=... RTMESH_DATA=... python3 lossless-io.py [RUNS]
"""
import os, shutil, statistics, subprocess, sys, time

OLD = os.environ.get('OLD', '/tmp/old-target/release/rtmesh')
NEW = os.environ.get('NEW', 'target/release/rtmesh')
DATA = os.environ.get('RTMESH_DATA', '../shared/meshes')


def prepare():
    if not os.path.exists('sponza_uv.obj'):
        shutil.copy(os.path.join(DATA, 'sponza_dabrovic.obj'), 'sponza_uv.obj')
    if os.path.exists('dragon_normals.ply'):
        return
    import numpy as np
    subprocess.run([NEW, 'convert', os.path.join(DATA, 'dragon_vrip.ply'), 'dragon_pos.ply'], check=True)
    data = open('dragon_pos.ply', 'rb').read()
    end = data.index(b'end_header\n') + len(b'end_header\n')
    header = data[:end].decode().splitlines()
    count = lambda name: int(next(l for l in header if l.startswith('element ' + name)).split()[2])
    nv, nf = count('vertex'), count('face')
    pos = np.frombuffer(data, dtype='<f4', count=nv * 3, offset=end).reshape(nv, 3)
    faces = np.frombuffer(data, dtype=np.dtype([('n', 'u1'), ('i', '<u4', 3)]), count=nf, offset=end + nv * 12)['i']
    a, b, c = pos[faces[:, 0]], pos[faces[:, 1]], pos[faces[:, 2]]
    face_normals = np.cross(b - a, c - a)
    normals = np.zeros((nv, 3))
    for k in range(3):
        np.add.at(normals, faces[:, k], face_normals)
    length = np.linalg.norm(normals, axis=1)
    length[length == 0] = 1
    normals = normals / length[:, None]
    with open('dragon_normals.ply', 'wb') as out:
        out.write((f'ply\nformat binary_little_endian 1.0\nelement vertex {nv}\n'
                   'property float x\nproperty float y\nproperty float z\n'
                   'property float nx\nproperty float ny\nproperty float nz\n'
                   f'element face {nf}\nproperty list uchar uint vertex_indices\nend_header\n').encode())
        out.write(np.hstack([pos, normals]).astype('<f4').tobytes())
        out.write(data[end + nv * 12:])


CASES = [
    ('dragon with normals, PLY -> PLY', ['convert', 'dragon_normals.ply', 'out.ply']),
    ('dragon with normals, PLY -> GLB', ['convert', 'dragon_normals.ply', 'out.glb']),
    ('sponza with UVs+normals, OBJ -> OBJ', ['convert', 'sponza_uv.obj', 'out.obj']),
    ('sponza with UVs+normals, OBJ -> GLB', ['convert', 'sponza_uv.obj', 'out.glb']),
]

if __name__ == '__main__':
    prepare()
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 11
    times = {(name, who): [] for name, _ in CASES for who in ('today', 'now')}
    for r in range(runs):
        for name, args in CASES:
            order = [('today', OLD), ('now', NEW)]
            for who, binary in (order if r % 2 == 0 else order[::-1]):
                start = time.perf_counter()
                subprocess.run([binary] + args, check=True, capture_output=True)
                times[(name, who)].append(time.perf_counter() - start)
    for name, _ in CASES:
        today, now = (statistics.median(times[(name, w)]) for w in ('today', 'now'))
        print(f'| {name} | {today * 1000:.0f} ms | {now * 1000:.0f} ms | {now / today:.2f}x |')
