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
import sys

from measure_images import fits_pixels, masked_arguments


def main():
    mask, (width, height, ref), images = masked_arguments(sys.argv, __doc__, fits_pixels)
    clamp = lambda x: min(max(x, 0.0), 1.0)
    for path in images:
        w, h, img = fits_pixels(path)
        if (w, h) != (width, height):
            raise SystemExit(f"{path}: {w}x{h}, the reference is {width}x{height}")
        total, n = 0.0, 0
        for i in mask:
            for k in range(3):
                d = clamp(img[i][k]) - clamp(ref[i][k])
                total += d * d
                n += 1
        print(f"{path} {10 * math.log10(n / total) if total > 0 else 99.0:.2f}")


main()
