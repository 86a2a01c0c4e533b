"""The numeric conventions of the raster core, restated in Python.

These mirror ``cpp/include/zbuffer/conventions.h`` so that the numpy reference
needs no compiled code; ``tests/test_conventions.py`` checks that both agree.
"""

SUBPIXEL_BITS = 8                  # window x, y are snapped to 1/256 pixel
SUBPIXEL_SCALE = 1 << SUBPIXEL_BITS
HALF_PIXEL = SUBPIXEL_SCALE // 2   # pixel centres sit at 256 i + 128
MAX_IMAGE_SIDE = 32768             # largest width or height
MAX_IMAGE_PIXELS = 1 << 27         # largest width * height
GUARD_BAND_PX = 32768.0            # x/y clipping only this far from the image centre
MIN_CLIP_W = 1e-300                # clip-space w below this: at or behind the eye
MAX_CLIP_VERTICES = 9              # a clipped triangle has at most 3 + 6 corners
