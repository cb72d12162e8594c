#!/usr/bin/python3
"""Screenshot of the whole X display ($DISPLAY) as PNG, with libX11 through ctypes.

Neither ImageMagick's `import` nor `xwd` is installed here; this reads the root window with
XGetImage (what those tools do) and writes an RGB PNG with zlib.
Usage: xshot.py OUT.png [--compare CANVAS.ppm]
--compare: report which share of the canvas the viewer saved itself (binary PPM, BGR written by
OpenCV as RGB) is found unchanged at the top-left of the screen, i.e. in its window.
"""
import ctypes
import ctypes.util
import struct
import sys
import zlib

import numpy as np


class XImage(ctypes.Structure):
    # Leading fields of Xlib's struct _XImage (X11/Xlib.h); the function table is not needed.
    _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("xoffset", ctypes.c_int),
                ("format", ctypes.c_int), ("data", ctypes.POINTER(ctypes.c_ubyte)),
                ("byte_order", ctypes.c_int), ("bitmap_unit", ctypes.c_int),
                ("bitmap_bit_order", ctypes.c_int), ("bitmap_pad", ctypes.c_int),
                ("depth", ctypes.c_int), ("bytes_per_line", ctypes.c_int),
                ("bits_per_pixel", ctypes.c_int), ("red_mask", ctypes.c_ulong),
                ("green_mask", ctypes.c_ulong), ("blue_mask", ctypes.c_ulong)]


class XWindowAttributes(ctypes.Structure):
    _fields_ = [("x", ctypes.c_int), ("y", ctypes.c_int), ("width", ctypes.c_int),
                ("height", ctypes.c_int), ("border_width", ctypes.c_int), ("depth", ctypes.c_int),
                ("visual", ctypes.c_void_p), ("root", ctypes.c_ulong), ("rest", ctypes.c_byte * 256)]


def png_bytes(rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data +
                struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def read_ppm(path):
    with open(path, "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:  # P6 width height maxval, whitespace separated
        while data[pos:pos + 1].isspace():
            pos += 1
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    if fields[0] != b"P6" or fields[3] != b"255":
        sys.exit("xshot.py: %s is not an 8-bit binary PPM" % path)
    w, h = int(fields[1]), int(fields[2])
    return np.frombuffer(data[pos + 1:pos + 1 + w * h * 3], dtype=np.uint8).reshape(h, w, 3)


def main():
    if len(sys.argv) not in (2, 4) or (len(sys.argv) == 4 and sys.argv[2] != "--compare"):
        sys.exit("usage: xshot.py OUT.png [--compare CANVAS.ppm]")
    x11 = ctypes.cdll.LoadLibrary(ctypes.util.find_library("X11") or "libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    x11.XGetWindowAttributes.argtypes = [ctypes.c_void_p, ctypes.c_ulong,
                                         ctypes.POINTER(XWindowAttributes)]
    x11.XGetImage.restype = ctypes.POINTER(XImage)
    x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                              ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = x11.XOpenDisplay(None)
    if not display:
        sys.exit("xshot.py: cannot open display (is DISPLAY set?)")
    root = x11.XDefaultRootWindow(display)
    attrs = XWindowAttributes()
    x11.XGetWindowAttributes(display, root, ctypes.byref(attrs))
    all_planes = (1 << 64) - 1
    z_pixmap = 2
    image = x11.XGetImage(display, root, 0, 0, attrs.width, attrs.height, all_planes, z_pixmap)
    if not image:
        sys.exit("xshot.py: XGetImage failed")
    img = image.contents
    if img.bits_per_pixel != 32:
        sys.exit("xshot.py: %d bits per pixel not supported" % img.bits_per_pixel)
    buf = ctypes.string_at(img.data, img.bytes_per_line * img.height)
    pix = np.frombuffer(buf, dtype=np.uint32).reshape(img.height, img.bytes_per_line // 4)
    pix = pix[:, :img.width]

    def channel(mask):
        shift = (mask & -mask).bit_length() - 1
        return ((pix & mask) >> shift).astype(np.uint8)

    rgb = np.dstack([channel(img.red_mask), channel(img.green_mask), channel(img.blue_mask)])
    with open(sys.argv[1], "wb") as f:
        f.write(png_bytes(np.ascontiguousarray(rgb)))
    print("xshot.py: %dx%d display -> %s" % (img.width, img.height, sys.argv[1]))
    x11.XCloseDisplay(display)
    if len(sys.argv) == 4:
        canvas = read_ppm(sys.argv[3])
        h, w, _ = canvas.shape
        if h > rgb.shape[0] or w > rgb.shape[1]:
            sys.exit("xshot.py: canvas %dx%d larger than the display" % (w, h))
        same = np.all(rgb[:h, :w] == canvas, axis=2).mean()
        print("xshot.py: %.2f%% of the %dx%d canvas the viewer drew is on screen unchanged"
              % (100.0 * same, w, h))
        if same < 0.99:
            sys.exit("xshot.py: the window does not show the viewer's canvas")


if __name__ == "__main__":
    main()
