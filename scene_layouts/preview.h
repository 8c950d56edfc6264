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

#include "mocap_io/output_file.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/visibility.h"

namespace odyssey::scene {

// The frames a contact sheet of a shot of `frames` frames shows.
std::vector<int> preview_frames(int frames);

// A contact-sheet tile: one frame as the camera's depth buffer saw it, RGB.
struct PreviewFrame {
  int frame = 0;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // width x height x 3, rows from the top
};

// Draws the last render of `buffer`; `owner` maps a triangle of that render to its owner (actor
// index >= 0, or < 0 for a prop).
PreviewFrame draw_preview(const DepthBuffer& buffer, const std::function<int(std::uint32_t)>& owner, int frame);

// Adds the points of one frame (uv: 2 per point; codes: io::kVisible ...) and the trails
// (trail_uv[k]: the uv of the trailed points k frames ago, oldest first; NaN where not valid).
void draw_points(PreviewFrame& image, std::span<const float> uv, std::span<const std::uint8_t> codes,
                 std::span<const std::vector<float>> trail_uv);

// Draws the preview frames of camera `camera` as the frame loop classifies them, keeping the
// trails' ring, and writes them as one PNG at finish().
class ContactSheetSink : public StreamSink {
 public:
  // `frames`: the shot's frame count, which decides the frames drawn.
  ContactSheetSink(int camera, int frames, const std::string& path, io::StagedOutputs& staged);
  void camera_frame(const CameraFrame& frame) override;
  void finish(const SceneResult&) override;
  std::vector<std::string> files() const override { return {path_}; }

 private:
  int camera_;
  std::string path_, staged_;
  std::vector<int> frames_;  // preview_frames of the shot
  // Trails: the uv of every kTrailStride-th point over the last kTrailFrames frames, a ring; NaN
  // where the point was not valid.
  std::vector<std::vector<float>> trail_;
  std::size_t trail_next_ = 0;
  std::vector<PreviewFrame> tiles_;
};

}  // namespace odyssey::scene
