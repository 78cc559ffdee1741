#!/usr/bin/env python3
"""PSNR over object pixels of 8-bit PNG renders (colours clamped to [0, 1] by the PNG), standard
library only. Used by scripts/measure/aa-measure.sh.

    aa_psnr.py MASK_A.png MASK_B.png REFERENCE.png IMAGE.png...

Object pixels are where MASK_A and MASK_B differ: two single-interface renders of the same view at
two IORs, which change every object pixel and no background pixel. Prints one PSNR (dB) per IMAGE.
"""
import math
import sys

from measure_images import masked_arguments, png_pixels


def main():
    mask, (_, _, ref), images = masked_arguments(sys.argv, __doc__, png_pixels)
    for path in images:
        _, _, img = png_pixels(path)
        se = sum((img[i][k] - ref[i][k]) ** 2 for i in mask for k in range(3))
        mse = se / (3 * len(mask) * 255.0 * 255.0)
        psnr = float("inf") if mse == 0 else 10 * math.log10(1.0 / mse)
        print(f"{path}\t{psnr:.2f}\t{len(mask)} object pixels")


main()
