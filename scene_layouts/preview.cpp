#include "scene_layouts/preview.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "mocap_io/png_file.h"
#include "mocap_io/trajectory_file.h"

namespace odyssey::scene {
namespace {

using Rgb = std::array<std::uint8_t, 3>;

constexpr Rgb kBackground{40, 40, 46};
constexpr Rgb kPropColour{176, 150, 112};
constexpr Rgb kVisibleColour{60, 230, 60};
constexpr Rgb kOccludedColour{230, 50, 40};
constexpr Rgb kTrailColour{240, 210, 40};
constexpr std::array<Rgb, 6> kActorColours{{{90, 140, 230}, {220, 120, 200}, {80, 200, 200}, {230, 160, 60},
                                            {150, 110, 230}, {120, 200, 100}}};

void put(PreviewFrame& image, int x, int y, const Rgb& colour) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return;
  std::uint8_t* pixel = &image.rgb[(std::size_t(y) * image.width + x) * 3];
  pixel[0] = colour[0];
  pixel[1] = colour[1];
  pixel[2] = colour[2];
}

// A line by uniform steps of at most half a pixel (trails are short).
void line(PreviewFrame& image, float x0, float y0, float x1, float y1, const Rgb& colour) {
  const int steps = static_cast<int>(std::ceil(2 * std::max(std::abs(x1 - x0), std::abs(y1 - y0)))) + 1;
  if (steps > 4 * (image.width + image.height)) return;  // a wild jump (a point leaving and re-entering the view)
  for (int s = 0; s <= steps; ++s) {
    const float t = static_cast<float>(s) / steps;
    put(image, static_cast<int>(x0 + t * (x1 - x0)), static_cast<int>(y0 + t * (y1 - y0)), colour);
  }
}

}  // namespace

std::vector<int> preview_frames(int frames) {
  std::vector<int> picked;
  const int tiles = std::min(frames, 6);
  for (int k = 0; k < tiles; ++k) {
    const int frame = tiles == 1 ? 0 : static_cast<int>(std::lround(double(k) * (frames - 1) / (tiles - 1)));
    if (picked.empty() || picked.back() != frame) picked.push_back(frame);
  }
  return picked;
}

PreviewFrame draw_preview(const DepthBuffer& buffer, const std::function<int(std::uint32_t)>& owner, int frame) {
  PreviewFrame image;
  image.frame = frame;
  image.width = buffer.width();
  image.height = buffer.height();
  image.rgb.resize(std::size_t(image.width) * image.height * 3);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::uint32_t triangle = buffer.triangle_at(x, y);
      Rgb colour = kBackground;
      if (triangle != 0xffffffff) {
        const int who = owner(triangle);
        const Rgb& base = who >= 0 ? kActorColours[who % kActorColours.size()] : kPropColour;
        const double shade = 0.35 + 0.65 * buffer.facing(triangle);
        for (int c = 0; c < 3; ++c) colour[c] = static_cast<std::uint8_t>(base[c] * shade);
      }
      put(image, x, y, colour);
    }
  }
  return image;
}

void draw_points(PreviewFrame& image, std::span<const float> uv, std::span<const std::uint8_t> codes,
                 std::span<const std::vector<float>> trail_uv) {
  for (std::size_t k = 1; k < trail_uv.size(); ++k) {
    const std::vector<float>& before = trail_uv[k - 1];
    const std::vector<float>& after = trail_uv[k];
    for (std::size_t i = 0; 2 * i + 1 < std::min(before.size(), after.size()); ++i) {
      if (std::isnan(before[2 * i]) || std::isnan(after[2 * i])) continue;
      line(image, before[2 * i], before[2 * i + 1], after[2 * i], after[2 * i + 1], kTrailColour);
    }
  }
  for (std::size_t i = 0; i < codes.size(); ++i) {
    if (codes[i] > io::kOccludedByProp) continue;
    const int x = static_cast<int>(uv[2 * i]), y = static_cast<int>(uv[2 * i + 1]);
    if (codes[i] == io::kVisible) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) put(image, x + dx, y + dy, kVisibleColour);
      }
    } else {
      put(image, x, y, kOccludedColour);
    }
  }
}

namespace {
constexpr std::size_t kTrailFrames = 15, kTrailStride = 8;
}  // namespace

ContactSheetSink::ContactSheetSink(int camera, int frames, const std::string& path, io::StagedOutputs& staged)
    : camera_(camera), path_(path), staged_(staged.stage(path)), frames_(preview_frames(frames)) {}

void ContactSheetSink::camera_frame(const CameraFrame& frame) {
  if (frame.camera != camera_) return;
  const std::size_t n = frame.codes.size();
  if (trail_.empty()) trail_.assign(kTrailFrames, std::vector<float>(2 * ((n + kTrailStride - 1) / kTrailStride), NAN));
  std::vector<float>& trail = trail_[trail_next_];
  for (std::size_t i = 0; i < n; i += kTrailStride) {
    trail[2 * (i / kTrailStride)] = frame.valid[i] ? frame.uv[2 * i] : NAN;
    trail[2 * (i / kTrailStride) + 1] = frame.valid[i] ? frame.uv[2 * i + 1] : NAN;
  }
  trail_next_ = (trail_next_ + 1) % kTrailFrames;
  if (!std::binary_search(frames_.begin(), frames_.end(), frame.frame)) return;
  PreviewFrame image = draw_preview(*frame.depth, [&](std::uint32_t t) { return frame.owner(t); }, frame.frame);
  std::vector<std::vector<float>> oldest_first;
  for (std::size_t k = 0; k < kTrailFrames; ++k) oldest_first.push_back(trail_[(trail_next_ + k) % kTrailFrames]);
  draw_points(image, frame.uv, frame.codes, oldest_first);
  tiles_.push_back(std::move(image));
}

void ContactSheetSink::finish(const SceneResult&) {
  if (tiles_.empty()) return;
  // Half-size tiles (each output pixel the mean of a 2x2 block), three to a row, 4 px apart.
  constexpr int kGap = 4;
  const int tile_w = std::max(1, tiles_[0].width / 2), tile_h = std::max(1, tiles_[0].height / 2);
  const int columns = std::min<int>(3, static_cast<int>(tiles_.size()));
  const int rows = (static_cast<int>(tiles_.size()) + columns - 1) / columns;
  const int width = columns * tile_w + (columns - 1) * kGap, height = rows * tile_h + (rows - 1) * kGap;
  std::vector<std::uint8_t> sheet(std::size_t(width) * height * 3, 255);
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    const PreviewFrame& tile = tiles_[t];
    const int left = static_cast<int>(t % columns) * (tile_w + kGap), top = static_cast<int>(t / columns) * (tile_h + kGap);
    for (int y = 0; y < tile_h; ++y) {
      for (int x = 0; x < tile_w; ++x) {
        for (int c = 0; c < 3; ++c) {
          int sum = 0, count = 0;
          for (int dy = 0; dy < 2; ++dy) {
            for (int dx = 0; dx < 2; ++dx) {
              const int sx = 2 * x + dx, sy = 2 * y + dy;
              if (sx < tile.width && sy < tile.height) {
                sum += tile.rgb[(std::size_t(sy) * tile.width + sx) * 3 + c];
                ++count;
              }
            }
          }
          sheet[(std::size_t(top + y) * width + left + x) * 3 + c] = static_cast<std::uint8_t>(sum / std::max(count, 1));
        }
      }
    }
  }
  io::write_png_rgb(staged_, width, height, sheet);
}

}  // namespace odyssey::scene
