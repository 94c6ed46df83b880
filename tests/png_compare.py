#!/usr/bin/env python3
# png_compare.py: compares two 8-bit PNGs pixel by pixel with only the standard library (zlib + filter reversal).
#
#   png_compare.py same A B [MAX]   exit 0 when every channel differs by at most MAX (default 1)
#   png_compare.py darker A B       exit 0 when B differs from A and its mean RGB is lower
#   png_compare.py cornell A        exit 0 when A looks like the default scene: red left wall,
#                                   green right wall, lit floor, nothing pure black in the room
#
# Only what pmview writes needs decoding: non-interlaced, bit depth 8, grey/RGB/grey+alpha/RGBA;
# anything else is refused rather than misread. A file ending in .xwd is read as an X window dump
# (xwd -id WINDOW: ZPixmap, TrueColor, 24 or 32 bits per pixel), so the window test can compare
# what the window really shows. The last line printed says what was found.
import struct
import sys
import zlib

CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}


def read_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("%s: not a PNG" % path)
    pos, idat, header = 8, [], None
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    if header is None:
        raise ValueError("%s: no IHDR" % path)
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in CHANNELS or interlace:
        raise ValueError("%s: unsupported PNG (depth %d, colour type %d, interlace %d)" % (path, depth, colour, interlace))
    bpp = CHANNELS[colour]
    raw = zlib.decompress(b"".join(idat))
    stride = width * bpp
    if len(raw) < height * (stride + 1):
        raise ValueError("%s: truncated image data" % path)
    rows, prev = [], bytearray(stride)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if kind == 0:
                p = 0
            elif kind == 1:
                p = a
            elif kind == 2:
                p = b
            elif kind == 3:
                p = (a + b) // 2
            elif kind == 4:
                est = a + b - c
                pa, pb, pc = abs(est - a), abs(est - b), abs(est - c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            else:
                raise ValueError("%s: bad filter type %d in row %d" % (path, kind, y))
            line[i] = (line[i] + p) & 255
        rows.append(line)
        prev = line
    # as RGB triples, so images with and without alpha compare
    pixels = []
    for line in rows:
        for x in range(width):
            px = line[x * bpp:(x + 1) * bpp]
            pixels.append((px[0], px[0], px[0]) if bpp <= 2 else (px[0], px[1], px[2]))
    return width, height, pixels


def read_xwd(path):
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 100:
        raise ValueError("%s: too short for an X window dump" % path)
    h = struct.unpack(">25I", data[:100])
    header_size, version, fmt, _, width, height = h[0], h[1], h[2], h[3], h[4], h[5]
    byte_order, bpp, bytes_per_line = h[7], h[11], h[12]
    masks, ncolors = (h[14], h[15], h[16]), h[19]
    if version != 7 or fmt != 2 or bpp not in (24, 32):
        raise ValueError("%s: unsupported X window dump (version %d, format %d, %d bits per pixel)" % (path, version, fmt, bpp))
    pos = header_size + 12 * ncolors
    if len(data) < pos + height * bytes_per_line:
        raise ValueError("%s: truncated image data" % path)
    shifts = [(m & -m).bit_length() - 1 for m in masks]
    step, order = bpp // 8, "little" if byte_order == 0 else "big"
    pixels = []
    for y in range(height):
        row = data[pos + y * bytes_per_line:pos + (y + 1) * bytes_per_line]
        for x in range(width):
            v = int.from_bytes(row[x * step:(x + 1) * step], order)
            pixels.append(tuple((v & m) >> sh for m, sh in zip(masks, shifts)))
    return width, height, pixels


def read_image(path):
    return read_xwd(path) if path.endswith(".xwd") else read_png(path)


def region_mean(w, pixels, x0, y0, x1, y1):
    s, n = [0, 0, 0], 0
    for y in range(y0, y1):
        for x in range(x0, x1):
            p = pixels[y * w + x]
            for c in range(3):
                s[c] += p[c]
            n += 1
    return [v / max(n, 1) for v in s]


def cornell(path):
    try:
        w, h, px = read_png(path)
    except (OSError, ValueError, zlib.error) as e:
        print("png_compare: %s" % e)
        return 1
    left = region_mean(w, px, w // 40, h // 3, w // 10, 2 * h // 3)
    right = region_mean(w, px, w - w // 10, h // 3, w - w // 40, 2 * h // 3)
    floor = region_mean(w, px, w // 3, h - h // 12, 2 * w // 3, h - 1)
    ok = left[0] > 2 * left[1] and left[0] > 2 * left[2] and right[1] > 1.5 * right[0] and right[1] > 1.5 * right[2] \
        and sum(floor) / 3 > 40
    print("png_compare: left %s right %s floor %s: %s" % ([round(v) for v in left], [round(v) for v in right],
                                                          [round(v) for v in floor], "ok" if ok else "not the Cornell box"))
    return 0 if ok else 1


def lit(path):
    try:
        w, h, px = read_image(path)
    except (OSError, ValueError, zlib.error) as e:
        print("png_compare: %s" % e)
        return 1
    mean = sum(sum(p) for p in px) / (3.0 * len(px))
    print("png_compare: %s mean %.2f: %s" % (path, mean, "lit" if mean > 10 else "black"))
    return 0 if mean > 10 else 1


def main(argv):
    if len(argv) == 3 and argv[1] == "cornell":
        return cornell(argv[2])
    if len(argv) == 3 and argv[1] == "lit":
        return lit(argv[2])
    if len(argv) >= 4 and argv[1] == "differ":
        wa, ha, a = read_image(argv[2])
        wb, hb, b = read_image(argv[3])
        changed = sum(1 for pa, pb in zip(a, b) if max(abs(x - y) for x, y in zip(pa, pb)) > 24)
        print("png_compare: %d of %d pixels changed by more than 24" % (changed, len(a)))
        return 0 if (wa, ha) == (wb, hb) and changed > len(a) // 20 else 1
    if len(argv) < 4 or argv[1] not in ("same", "darker"):
        print("usage: png_compare.py same|darker A B [MAX] | differ A B | cornell A | lit A")
        return 2
    try:
        wa, ha, a = read_image(argv[2])
        wb, hb, b = read_image(argv[3])
    except (OSError, ValueError, zlib.error) as e:
        print("png_compare: %s" % e)
        return 1
    if (wa, ha) != (wb, hb):
        print("png_compare: sizes differ: %dx%d vs %dx%d" % (wa, ha, wb, hb))
        return 1
    max_diff, worst = 0, (0, 0)
    for i, (pa, pb) in enumerate(zip(a, b)):
        d = max(abs(x - y) for x, y in zip(pa, pb))
        if d > max_diff:
            max_diff, worst = d, (i % wa, i // wa)
    mean_a = sum(sum(p) for p in a) / (3.0 * len(a))
    mean_b = sum(sum(p) for p in b) / (3.0 * len(b))
    if argv[1] == "same":
        limit = int(argv[4]) if len(argv) > 4 else 1
        print("png_compare: %dx%d, max channel difference %d (at %d,%d), limit %d" % (wa, ha, max_diff, worst[0], worst[1], limit))
        return 0 if max_diff <= limit else 1
    print("png_compare: mean %.2f -> %.2f, max channel difference %d" % (mean_a, mean_b, max_diff))
    return 0 if max_diff > 0 and mean_b < mean_a else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
