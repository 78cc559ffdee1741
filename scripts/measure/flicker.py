#!/usr/bin/env python3
"""Temporal flicker of an orbit (docs/technique.md, "Temporal stability"), standard library only.

    flicker.py DIR FRAMES MODE...

DIR holds, per frame t (0..FRAMES-1), mask_a_t.png and mask_b_t.png (single-interface renders at
two IORs: they differ on every object pixel) and MODE_t.png for every MODE. The flicker of a MODE
is the mean over consecutive frames of the mean absolute change of the 8-bit colour (0..1) over the
pixels that are object pixels in either frame. Prints one line per MODE, then each MODE's flicker
relative to the first MODE's (the reference).
"""
import os
import sys

from measure_images import object_pixels, png_pixels


def main():
    if len(sys.argv) < 4:
        raise SystemExit(__doc__)
    folder, frames, modes = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    masks = []
    for t in range(frames):
        _, _, a = png_pixels(os.path.join(folder, f"mask_a_{t}.png"))
        _, _, b = png_pixels(os.path.join(folder, f"mask_b_{t}.png"))
        masks.append(set(object_pixels(a, b)))
    results = []
    for mode in modes:
        images = [png_pixels(os.path.join(folder, f"{mode}_{t}.png"))[2] for t in range(frames)]
        total = 0.0
        for t in range(1, frames):
            region = masks[t] | masks[t - 1]
            change = sum(abs(images[t][i][k] - images[t - 1][i][k]) for i in region for k in range(3))
            total += change / (3 * 255.0 * max(len(region), 1))
        flicker = total / (frames - 1)
        results.append((mode, flicker))
        print(f"{mode}\tflicker {flicker:.5f}")
    reference = results[0][1]
    for mode, flicker in results[1:]:
        print(f"{mode}\t{flicker / reference:.3f} x {results[0][0]}")


main()
