"""Image readers and object pixels shared by the measurement helpers beside it (aa_psnr.py,
linear_psnr.py, flicker.py). Standard library only.

Object pixels are where two single-interface renders of the same view at two IORs differ: every
object pixel and no background pixel.
"""
import struct
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


def png_pixels(path):
    """(width, height, an RGB tuple of 0..255 per pixel) of an 8-bit PNG."""
    w, h, ch, rows = read_png(path)
    return w, h, [tuple(r[x * ch:x * ch + 3]) for r in rows for x in range(w)]


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


def fits_pixels(path):
    """(width, height, an RGB tuple of floats per pixel) of a FITS image read_fits reads."""
    w, h, values = read_fits(path)
    return w, h, [values[3 * i:3 * i + 3] for i in range(w * h)]


def object_pixels(mask_a, mask_b):
    """The indices of the pixels where the two masks' renders differ."""
    return [i for i in range(len(mask_a)) if mask_a[i] != mask_b[i]]


def masked_arguments(argv, usage, pixels):
    """A PSNR helper's command line, MASK_A MASK_B REFERENCE IMAGE... (read with `pixels`): the
    object pixels, the reference's (width, height, pixels) and the IMAGE paths; exits with `usage`
    when it is short."""
    if len(argv) < 5:
        raise SystemExit(usage)
    mask = object_pixels(pixels(argv[1])[2], pixels(argv[2])[2])
    return mask, pixels(argv[3]), argv[4:]
