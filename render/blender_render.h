// RGB frames of a sequence folder (scene_layouts/pointodyssey.h) rendered by Blender: Cycles on the
// CPU, headless, on the shot's scene.glb (beside the sequence folder), through a camera placed at
// every frame's extrinsics and intrinsics from the folder's anno.npz, written as
// rgbs/rgb_%05d.jpg. Frame k of rgbs/ is frame k of the annotations: the same instant as frame k
// of scene.glb (time k / fps).
//
// The work is Blender's: render/blender/render_sequence.py (installed under share/odyssey/render,
// found through io::runtime_folder) imports the GLB, places the camera (its header writes out the
// OpenCV -> Blender axes, the sensor fit that makes fx and fy exact and the lens shift that puts
// the principal point at (cx, cy)), adds a sun and a sky-coloured world, and renders. This library
// checks the folder, finds Blender, runs it with the script and checks what it wrote.
//
// Invariants. rgbs/ appears whole or not at all: Blender writes into a temporary folder beside it
// (io::StagedOutputs::stage_folder) which is renamed onto rgbs/ only when every asked frame is a
// JPEG of the asked size; a rerun replaces an earlier rgbs/ whole, and only when it succeeds. Bad
// input throws io::InputError naming the file and the problem (not a sequence folder, no
// scene.glb, Blender not found or failing: its last error line), and leaves nothing behind.
#pragma once

#include <functional>
#include <string>

namespace odyssey::render {

// What a sequence folder says about its shot and camera.
struct Sequence {
  std::string folder;          // the sequence folder, absolute
  std::string glb;             // folder/../scene.glb, absolute
  std::string camera;          // scene_info.json's camera name
  int width = 0, height = 0;   // scene_info.json's camera size: the image the intrinsics are in
  int frames = 0;              // anno.npz's frame count (= scene_info.json's "frames")
  double fps = 0;              // scene_info.json's frame rate
};

// Reads and checks `folder`: scene_info.json (camera size, fps, frames), anno.npz (intrinsics
// [T,3,3] with positive finite focal lengths, extrinsics [T,4,4], T = frames) and scene.glb beside
// the folder. io::InputError naming the first file that is missing or wrong.
Sequence read_sequence(const std::string& folder);

// Frames [first, end) of a sequence.
struct FrameRange {
  int first = 0;
  int end = 0;
};

// "A:B" (frames A to B - 1, as a Python slice; A defaults to 0 and B to `frames`) or "K" (frame K
// alone). std::invalid_argument saying what was expected when the text is not that or the range
// is empty or outside [0, frames).
FrameRange parse_frame_range(const std::string& text, int frames);

// The Blender executable: $ODYSSEY_BLENDER when set (it must name an executable file), else
// `blender` on $PATH. io::InputError naming it when there is none.
std::string find_blender();

// The Blender-side script, render_sequence.py: installed under share/odyssey/render, else the
// source tree's render/blender.
std::string render_script();

struct RenderResult {
  std::string folder;  // the rgbs/ folder written
  int frames = 0;
  int width = 0, height = 0;
  double seconds = 0;  // Blender's run, import included
};

// One `odyssey render`: a plain struct of inputs; run() renders and commits rgbs/.
struct RenderJob {
  Sequence sequence;     // read_sequence()'s
  FrameRange frames;     // default (empty): every frame
  int samples = 64;      // Cycles samples per pixel
  double scale = 1.0;    // image size = the camera's size x scale, rounded
  std::string blender;   // executable; empty: find_blender()
  std::function<void(int frame)> on_frame;  // called as Blender finishes each frame (progress)

  // The output size for `scale`.
  int width() const;
  int height() const;
  // Empty when the job can run, else what is wrong with it (samples, scale, frames).
  std::string validate() const;
  // Throws std::invalid_argument with validate()'s text, io::InputError for the failures above.
  RenderResult run() const;
};

}  // namespace odyssey::render
