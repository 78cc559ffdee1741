#!/usr/bin/env python3
"""PSNR over object pixels of 8-bit PNG renders (colours clamped to [0, 1] by the PNG), standard
library only. Used by scripts/measure/aa-measure.sh and flicker.py.

    aa_psnr.py MASK_A.png MASK_B.png REFERENCE.png IMAGE.png...

Object pixels are where MASK_A and MASK_B differ: two single-interface renders of the same view at
two IORs, which change every object pixel and no background pixel. Prints one PSNR (dB) per IMAGE.
"""
import math
import struct
import sys
import zlib


def read_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            if depth != 8 or colour not in (2, 6):
                raise SystemExit(f"{path}: only 8-bit RGB or RGBA PNGs")
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        base = y * (stride + 1)
        ftype, line = raw[base], bytearray(raw[base + 1:base + 1 + stride])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return width, height, channels, rows


def pixels(path):
    w, h, ch, rows = read_png(path)
    return w, h, [tuple(r[x * ch:x * ch + 3]) for r in rows for x in range(w)]


def main():
    if len(sys.argv) < 5:
        raise SystemExit(__doc__)
    _, _, a = pixels(sys.argv[1])
    _, _, b = pixels(sys.argv[2])
    _, _, ref = pixels(sys.argv[3])
    mask = [i for i in range(len(a)) if a[i] != b[i]]
    for path in sys.argv[4:]:
        _, _, img = pixels(path)
        se = sum((img[i][k] - ref[i][k]) ** 2 for i in mask for k in range(3))
        mse = se / (3 * len(mask) * 255.0 * 255.0)
        psnr = float("inf") if mse == 0 else 10 * math.log10(1.0 / mse)
        print(f"{path}\t{psnr:.2f}\t{len(mask)} object pixels")


main()
