// Dense annotations of one camera-frame, from the depth buffer the frame loop drew for visibility
// (one rasterisation serves both): per pixel, sampled at its centre (x + 0.5, y + 0.5) like the
// buffer,
//   depth     the camera z of the nearest surface, metres along the optical axis (Blender's Z
//             pass); +infinity where no surface covers the centre;
//   normal    the surface's unit normal in the world (Z up), turned to face the camera: the
//             render's area-weighted vertex normals (camera space, summed over the triangles of
//             the render that use the vertex, made unit length as a renderer's NORMAL attribute
//             is) interpolated with the barycentric coordinates of
//             the point where the centre's ray meets the triangle, normalised, then R^T n; (0, 0, 0)
//             where no surface;
//   instance  the id of the surface's owner: 0 nothing, then the actors 1 ... A in the shot's
//             order, then the props A + 1 ... A + P in theirs (instance_id below).
// The ray through a centre meets the triangle's plane at s d, d = ((x + 0.5 - cx) / fx,
// (y + 0.5 - cy) / fy, 1), s = (n . a) / (n . d) for the plane through corner a with normal n; the
// barycentrics of that point are clamped to the triangle (the buffer covers centres up to 1/1024
// px outside it) and renormalised.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "scene_layouts/frame_loop.h"
#include "skinning/worker_pool.h"

namespace odyssey::scene {

// The instance id of an owner (CameraFrame::owner): actor a -> 1 + a, prop k -> 1 + actors + k.
inline int instance_id(int owner, int actors) { return owner >= 0 ? 1 + owner : 1 + actors + (-1 - owner); }

struct DenseMaps {
  int width = 0, height = 0;
  std::vector<float> depth;               // width x height, row-major from the top
  std::vector<float> normals;             // width x height x 3
  std::vector<std::uint16_t> instances;  // width x height
  std::vector<Eigen::Vector3d> vertex_normals;  // scratch: the render's vertex normals (camera space)
};

// Fills `maps` (resized to the frame's image) from the frame's last render; `actors` is the
// shot's actor count. Normals, the costly part, only when `normals` (else left empty). Reuses the
// maps' memory from frame to frame. With `workers`, the rows are filled in blocks spread over
// them (each pixel is computed the same way whichever thread fills it).
void fill_dense_maps(const CameraFrame& frame, int actors, DenseMaps& maps, bool normals = true,
                     skinning::WorkerPool* workers = nullptr);

}  // namespace odyssey::scene
