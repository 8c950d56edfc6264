// Contact sheets: a few frames of a camera drawn by the toolkit's own rasteriser, for a person to
// check a shot before spending renderer hours on it. Each tile is the camera's depth buffer as
// the visibility test saw it: every pixel takes the flat colour of the owner of its nearest
// triangle (one colour per actor, one for the props), shaded by how squarely the triangle faces
// the camera (|cos| of the angle between its normal and the ray to it: 0.35 + 0.65 |cos|); then
// the tracked points on top, visible ones as green dots, occluded ones as red dots, and the last
// 15 frames of every 8th point's path as a yellow trail. Tiles are the frames at 0, 1/5, ..., 5/5
// of the shot (6 at most), half size, three to a row, in one PNG per camera.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "scene_layouts/streams.h"
#include "scene_layouts/visibility.h"

namespace odyssey::scene {

// The frames a contact sheet of a shot of `frames` frames shows.
std::vector<int> preview_frames(int frames);

// (PreviewFrame is in streams.h: the frame loop draws the tiles.) Draws the last render of `buffer`; `owner` maps a triangle of that render to its owner (actor
// index >= 0, or < 0 for a prop).
PreviewFrame draw_preview(const DepthBuffer& buffer, const std::function<int(std::uint32_t)>& owner, int frame);

// Adds the points of one frame (uv: 2 per point; codes: io::kVisible ...) and the trails
// (trail_uv[k]: the uv of the trailed points k frames ago, oldest first; NaN where not valid).
void draw_points(PreviewFrame& image, std::span<const float> uv, std::span<const std::uint8_t> codes,
                 std::span<const std::vector<float>> trail_uv);

// Collects the preview frames of camera `camera` and writes them as one PNG at finish().
class ContactSheetSink : public StreamSink {
 public:
  ContactSheetSink(int camera, std::string path) : camera_(camera), path_(std::move(path)) {}
  void write(const FrameChunk& chunk) override;
  void finish() override;

 private:
  int camera_;
  std::string path_;
  std::vector<PreviewFrame> tiles_;
};

}  // namespace odyssey::scene
