// zbuffer conventions: read this first.
//
// Every algorithm in zbuffer produces bit-identical depth and triangle ids
// because they all share one vertex stage (vertex_stage.h) and one raster core
// (raster.h) that implement the rules written in docs/rasterization.md. The
// numpy reference (python/zbuffer/reference.py) implements the same text.
//
//   Coordinates   Clip space follows OpenGL: right-handed eye space, the camera
//                 looks down -z, clip z in [-w, w], NDC y up.
//   Window        x to the right, y DOWN: row 0 is the top row of the image.
//                 x_win = (x_ndc + 1) * (W / 2), y_win = (1 - y_ndc) * (H / 2),
//                 z_win = z_ndc * 0.5 + 0.5, clamped to [0, 1].
//   Pixel centres Pixel (i, j) (column i, row j) has its centre at
//                 (i + 0.5, j + 0.5) in window coordinates.
//   Sub-pixels    Window x and y are snapped once, round-half-to-even, to
//                 fixed point with kSubpixelBits = 8 fractional bits.
//   Coverage      Integer edge functions at pixel centres, top-left fill rule:
//                 a centre on an edge shared by two triangles belongs to
//                 exactly one of them.
//   Depth         Smaller is nearer. Depth at a pixel is one formula of the
//                 exact integer edge values (raster.h): coefficients in
//                 double rounded once to float, then float32 operations in a
//                 fixed order, clamped to the triangle's own depth range.
//                 Never-written pixels hold +inf and id -1.
//   Depth write   Keep the smaller depth; on an exact tie the smaller triangle
//                 id. The result is a pure minimum: independent of the order
//                 triangles are visited in, of the algorithm and of threads.
//   Culling       Only on a strict test (tri_zmin > region_zmax): with >= a
//                 triangle that wins a tie on its id could be culled.
//   Floating pt   No -ffast-math, -ffp-contract=off (see cpp/CMakeLists.txt).
#pragma once

#include <cstdint>

namespace zbuffer {

// Fixed point: window coordinates are stored as round(x_win * 256).
constexpr int kSubpixelBits = 8;
constexpr int32_t kSubpixelScale = 1 << kSubpixelBits;   // 256
constexpr int32_t kHalfPixel = kSubpixelScale / 2;        // pixel centre offset

// Largest image side. Together with the guard band it bounds every snapped
// coordinate by 2^24 in magnitude, so edge functions (products of two
// coordinate differences) stay below 2^51: exact in int64 and in double.
constexpr int kMaxImageSide = 32768;
// Largest image, in pixels (1 GiB of depth plus ids, 1.375 GiB with the image).
constexpr int64_t kMaxImagePixels = int64_t(1) << 27;

// Guard band: triangles are clipped in x and y only where they leave the
// window by more than this many pixels on either side of its centre; inside
// the band the raster core simply skips pixels outside the image. The clip
// planes are |x| <= g_x * w with g_x = kGuardBandPx / (W / 2).
constexpr double kGuardBandPx = 32768.0;

// A clip-space w below this counts as at or behind the eye (outside the
// near plane): 1 / w must stay finite for the divide, and only an absurd
// camera (near ~1e-300) comes anywhere near it.
constexpr double kMinClipW = 1e-300;

}  // namespace zbuffer
