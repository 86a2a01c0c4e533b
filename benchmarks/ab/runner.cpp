// The A/B runner of benchmarks/ab.py: renders each scene with core A and
// core B (side.cpp, built from two source trees) in alternating turns of
// one process -- A B, then B A, and so on -- each turn two frames of its
// side with the second timed, and prints, per scene, one JSON line with
// every timed frame's time, the pixels tested and written, and whether the
// two cores drew the same bits (first and last frames). On a shared, noisy
// machine both sides see the same noise, so the ratio of their medians is
// what counts; the untimed frame puts the side's own arrays back in the
// caches, so that each timed frame follows one of its own, as frame after
// frame of one core would (timing every frame of A B B A ... gave each
// side's times two modes 7-15% apart on 1024 x 1024 frames -- after itself
// and after the other side -- and the median fell between them). With
// SHADING flat or smooth, each frame is shaded after it is rendered, and
// the time is the shading call's (the image is compared too).
//
//   runner FRAMES ALGO SHADING SCENE.bin...   (scenes written by benchmarks/ab.py;
//                                              SHADING: none, flat or smooth)
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "side.h"

namespace {

template <class T>
std::vector<T> read(FILE* f, int64_t n, const char* path) {
  std::vector<T> v(size_t(n > 0 ? n : 0));
  if (n > 0 && std::fread(v.data(), sizeof(T), size_t(n), f) != size_t(n)) {
    std::fprintf(stderr, "%s: truncated\n", path);
    std::exit(2);
  }
  return v;
}

// A frame's two planes in one allocation, 2 KiB apart modulo 4 KiB, their
// rows `pitch` pixels apart, as the planes of a Python result are
// (src/render_common.cpp, allocate_planes).
struct Planes {
  std::vector<char> memory;
  float* depth;
  int32_t* ids;
  int w, h, pitch;
  Planes(int w_, int h_, int pitch_) : w(w_), h(h_), pitch(pitch_) {
    const size_t n = size_t(pitch) * size_t(h);
    const size_t bytes = ((n * 4 + 4095) & ~size_t(4095)) + 2048;
    memory.resize(bytes + n * 4 + 4096);
    char* base = reinterpret_cast<char*>((reinterpret_cast<uintptr_t>(memory.data()) + 4095) &
                                         ~uintptr_t(4095));
    depth = reinterpret_cast<float*>(base);
    ids = reinterpret_cast<int32_t*>(base + bytes);
  }
  // FNV-1a over both planes' pixels (not their padding) and the image.
  uint64_t hash(const std::vector<uint8_t>& image) const {
    uint64_t hv = 1469598103934665603ull;
    auto mix = [&](const void* p, size_t bytes) {
      const unsigned char* c = static_cast<const unsigned char*>(p);
      for (size_t k = 0; k < bytes; ++k) hv = (hv ^ c[k]) * 1099511628211ull;
    };
    for (int y = 0; y < h; ++y) mix(depth + size_t(y) * pitch, size_t(w) * 4);
    for (int y = 0; y < h; ++y) mix(ids + size_t(y) * pitch, size_t(w) * 4);
    mix(image.data(), image.size());
    return hv;
  }
};

// The row pitch of the planes the Python binding allocates (types.h,
// padded_pitch): 16 pixels more at widths that are multiples of 512 from
// 1024 up.
int padded_pitch(int width) { return width >= 1024 && width % 512 == 0 ? width + 16 : width; }

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s FRAMES ALGO SHADING SCENE.bin...\n", argv[0]);
    return 2;
  }
  const int frames = std::atoi(argv[1]);
  const char* algo = argv[2];
  const std::string shading = argv[3];
  if (shading != "none" && shading != "flat" && shading != "smooth") {
    std::fprintf(stderr, "SHADING must be none, flat or smooth, not %s\n", shading.c_str());
    return 2;
  }
  constexpr int kWarmup = 3;
  for (int s = 4; s < argc; ++s) {
    const char* path = argv[s];
    FILE* f = std::fopen(path, "rb");
    if (!f) {
      std::fprintf(stderr, "%s: cannot open\n", path);
      return 2;
    }
    const std::vector<int64_t> head = read<int64_t>(f, 5, path);
    const int64_t nv = head[0], nf = head[1], nc = head[2];
    const int w = int(head[3]), h = int(head[4]);
    const std::vector<double> mvp = read<double>(f, 16, path);
    const std::vector<double> positions = read<double>(f, 3 * nv, path);
    const std::vector<int32_t> faces = read<int32_t>(f, 3 * nf, path);
    const std::vector<int32_t> face_ids = read<int32_t>(f, nf, path);
    const std::vector<int32_t> cell_start = read<int32_t>(f, nc > 0 ? nc + 1 : 0, path);
    const std::vector<double> cell_centre = read<double>(f, 3 * nc, path);
    // The mesh as the caller holds it (what the ids index), for shading.
    const std::vector<double> viewer = read<double>(f, 4, path);
    const std::vector<double> light = read<double>(f, 3, path);
    const std::vector<int64_t> sizes = read<int64_t>(f, 2, path);
    const std::vector<double> shade_positions = read<double>(f, 3 * sizes[0], path);
    const std::vector<int32_t> shade_faces = read<int32_t>(f, 3 * sizes[1], path);
    const std::vector<double> normals = read<double>(f, 3 * sizes[0], path);
    std::fclose(f);

    std::vector<uint8_t> images[2];
    AbShading shade[2];
    for (int side = 0; side < 2; ++side) {
      images[side].assign(shading == "none" ? 0 : size_t(w) * size_t(h) * 3, 0);
      shade[side] = {shade_positions.data(), sizes[0], shade_faces.data(), sizes[1],
                     shading == "smooth" ? normals.data() : nullptr, viewer.data(), light.data(),
                     images[side].data()};
    }
    // Each side draws into planes of its own, padded as its tree's Python
    // results are (a tree without a row pitch: contiguous).
    std::vector<Planes> planes;
    for (int side = 0; side < 2; ++side) planes.emplace_back(w, h, padded_pitch(w));
    std::vector<double> ms[2];
    double out[2][3] = {};
    uint64_t hash[2] = {0, 0}, last_hash[2] = {0, 0};
    for (int frame = 0; frame < kWarmup + frames; ++frame) {
      for (int turn = 0; turn < 2; ++turn) {
        const int side = (frame & 1) ? 1 - turn : turn;  // A B, B A, ...
        auto render = side == 0 ? ab_render_a : ab_render_b;
        auto draw = [&] {
          const Planes& p = planes[size_t(side)];
          return render(algo, positions.data(), nv, faces.data(), face_ids.data(), nf,
                        cell_start.empty() ? nullptr : cell_start.data(),
                        cell_centre.empty() ? nullptr : cell_centre.data(), nc, mvp.data(),
                        p.depth, p.ids, w, h, p.pitch, shading == "none" ? nullptr : &shade[side],
                        out[side]);
        };
        int status = 0;
        for (int repeat = 0; repeat < 2 && status == 0; ++repeat) {  // the second timed
          status = draw();
          if (status == 3) {  // a tree without a row pitch
            planes[size_t(side)] = Planes(w, h, w);
            status = draw();
          }
        }
        if (status != 0) {
          std::fprintf(stderr, "unknown algorithm %s\n", algo);
          return 2;
        }
        if (frame == 0) hash[side] = planes[size_t(side)].hash(images[side]);
        if (frame == kWarmup + frames - 1)
          last_hash[side] = planes[size_t(side)].hash(images[side]);
        if (frame >= kWarmup) ms[side].push_back(out[side][0]);
      }
    }
    int image_diff = 0;  // the largest difference of a channel between the two images
    for (size_t k = 0; k < images[0].size(); ++k)
      image_diff = std::max(image_diff, std::abs(int(images[0][k]) - int(images[1][k])));
    std::printf("{\"scene\": \"%s\", \"algo\": \"%s\", \"shading\": \"%s\", \"width\": %d, "
                "\"height\": %d, \"faces\": %lld, \"same_bits\": %s, \"image_max_diff\": %d, "
                "\"pitch\": [%d, %d], \"tested\": [%.0f, %.0f], \"written\": [%.0f, %.0f], "
                "\"ms\": [[",
                path, algo, shading.c_str(), w, h, static_cast<long long>(nf),
                hash[0] == hash[1] && last_hash[0] == last_hash[1] ? "true" : "false",
                image_diff, planes[0].pitch, planes[1].pitch,
                out[0][1], out[1][1], out[0][2], out[1][2]);
    for (int side = 0; side < 2; ++side) {
      for (size_t k = 0; k < ms[side].size(); ++k)
        std::printf("%s%.6f", k ? ", " : "", ms[side][k]);
      std::printf(side == 0 ? "], [" : "]]}\n");
    }
    std::fflush(stdout);
  }
  return 0;
}
