#!/usr/bin/env python3
"""Pixel values of the real test vectors decoded straight from their bytes with
numpy, independently of the C++ readers; tests/vision/footage_test.cpp checks
the readers against these numbers. Run: python3 tests/data/footage/independent_decode.py

beam.mraw: 4 frames of 1024 x 80, 16-bit words. The words are little-endian:
read as little-endian the maximum is 4095 (the header's 12 effective bits);
read big-endian it is 65295.
cine_781.cine: 15 images of 256 x 256, 16-bit little-endian, image offsets
(int64) at the CINEFILEHEADER's OffImageOffsets = 10820, each image after an
annotation block whose size is its first uint32; rows stored bottom-up.
"""
import os
import struct

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
d = np.fromfile(os.path.join(here, 'beam.mraw'), dtype='<u2').reshape(4, 80, 1024)
for f, r, c in [(0, 0, 0), (0, 0, 1), (0, 40, 512), (1, 10, 100), (2, 79, 1023), (3, 55, 700)]:
    print('mraw frame', f, 'row', r, 'col', c, '=', d[f, r, c])
print('mraw frame 0 sum', int(d[0].astype(np.int64).sum()), '; max of all frames', d.max())

b = open(os.path.join(here, 'cine_781.cine'), 'rb').read()
off_offsets = struct.unpack_from('<I', b, 32)[0]
offs = struct.unpack_from('<15q', b, off_offsets)


def cine_frame(i):
    o = offs[i]
    annotation = struct.unpack_from('<I', b, o)[0]
    img = np.frombuffer(b, dtype='<u2', count=256 * 256, offset=o + annotation)
    return img.reshape(256, 256)[::-1]  # bottom-up rows


for f, r, c in [(0, 0, 0), (0, 255, 255), (0, 128, 64), (7, 100, 200), (14, 10, 250), (14, 200, 30)]:
    print('cine frame', f, 'row', r, 'col', c, '=', cine_frame(f)[r, c])
print('cine frame 0 sum', int(cine_frame(0).astype(np.int64).sum()))
