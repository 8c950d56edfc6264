// Per-frame pose streams as npz, written in chunks of frames so memory does not grow with the
// sequence: a body model evaluated over a sequence (joints and vertices), or a clip's world
// joint positions. Written through NpzWriter, so a failure leaves no file at `out_path`.
#pragma once

#include <string>

#include "skeleton/body_model.h"
#include "skeleton/body_sequence.h"
#include "skeleton/clip.h"

namespace odyssey::io {

// Keys: joints [T,J,3] float32, vertices [T,V,3] float32 (unless joints_only), faces [F,3]
// uint32, fps (0-d float64), joint_names [J] (unicode), parents [J] int32. Positions are in the
// sequence's world (Z up for AMASS). The sequence must already be in the model's pose layout,
// with no more betas than the model has shape directions (fit them first: skeleton/betas.h).
// The mesh is evaluated on `threads` threads (0: default_pose_threads()) in batches of 128
// frames, written while the next batches are evaluated; the output is the same, bit for bit,
// whatever the thread count.
void export_body_poses(const BodyModel& model, const BodySequence& sequence, const BodyModelOptions& options,
                       bool joints_only, const std::string& out_path, int threads = 0);

// The thread count export_body_poses uses by default: every core (std::thread::hardware_concurrency).
int default_pose_threads();

// Keys: joints [T,J,3] float32 world positions, joint_names, parents, fps.
void export_clip_joints(const Clip& clip, const std::string& out_path);

}  // namespace odyssey::io
