#!/usr/bin/env python3
"""PSNR over object pixels of float renders, the linear measure of docs/performance.md (colours
clamped to [0, 1], the float images compared before any 8-bit rounding). Standard library only;
reads the FITS images scripts/measure/linear-measure.sh converts the tool's EXR renders to (oiiotool).

    linear_psnr.py MASK_A.fits MASK_B.fits REFERENCE.fits IMAGE.fits...

oiiotool 2.4's FITS files hold the image's rows bottom-up and one off: FITS row r is the image's row
H - r, and row 0 reads zeros (the image's top row, sky in every default view, is left out). Every
image alike, so the PSNRs hold; a pixel's (x, y) counted in the FITS data is not the image's.

Object pixels are where MASK_A and MASK_B differ: two single-interface renders of the same view at
two IORs, which change every object pixel and no background pixel. Prints one PSNR (dB) per IMAGE.
"""
import math
import struct
import sys


def read_fits(path):
    data = open(path, "rb").read()
    pos, header = 0, {}
    while True:  # 80-character cards in 2880-byte blocks, up to END
        block = data[pos:pos + 2880]
        pos += 2880
        if len(block) < 2880:
            raise SystemExit(f"{path}: not a FITS image (no END card)")
        cards = [block[i:i + 80].decode("ascii", "replace") for i in range(0, 2880, 80)]
        for card in cards:
            if card[8:10] == "= ":
                header[card[:8].strip()] = card[10:].split("/")[0].strip()
        if any(card[:8].strip() == "END" for card in cards):
            break
    if header.get("BITPIX") != "-32" or header.get("NAXIS") != "3":
        raise SystemExit(f"{path}: only 32-bit float images of 3 axes (channels, width, height)")
    channels, width, height = (int(header[k]) for k in ("NAXIS1", "NAXIS2", "NAXIS3"))
    count = channels * width * height
    if channels != 3 or len(data) < pos + 4 * count:
        raise SystemExit(f"{path}: expected 3 channels and {count} values")
    return width, height, struct.unpack(f">{count}f", data[pos:pos + 4 * count])


def main():
    if len(sys.argv) < 5:
        raise SystemExit(__doc__)
    _, _, a = read_fits(sys.argv[1])
    _, _, b = read_fits(sys.argv[2])
    width, height, ref = read_fits(sys.argv[3])
    mask = [a[3 * i:3 * i + 3] != b[3 * i:3 * i + 3] for i in range(width * height)]
    clamp = lambda x: min(max(x, 0.0), 1.0)
    for path in sys.argv[4:]:
        w, h, img = read_fits(path)
        if (w, h) != (width, height):
            raise SystemExit(f"{path}: {w}x{h}, the reference is {width}x{height}")
        total, n = 0.0, 0
        for i in range(width * height):
            if mask[i]:
                for k in range(3):
                    d = clamp(img[3 * i + k]) - clamp(ref[3 * i + k])
                    total += d * d
                    n += 1
        print(f"{path} {10 * math.log10(n / total) if total > 0 else 99.0:.2f}")


main()
