// The inner loop of linear blend skinning (lbs.h), for a block of vertices that all have C
// influences. Per vertex v with palette entries e_1..e_C and weights w_1..w_C:
//
//   M   = sum_k w_k P[e_k]                  (P[e] = W(joint) * inverse_bind, a float 4x4 with
//                                             bottom row (0, 0, 0, 1), column-major as glm::mat4)
//   p   = M (x, y, z, 1)                    -> positions[3 row(v) + 0..2]
//   n   = normalise( M (nx, ny, nz, 0) )    -> normals[3 row(v) + 0..2]   (when asked)
//
// Why one vertex at a time. Transforming by each entry and blending the results costs 12 C
// multiply-adds a vertex instead of 16 C + 16, but vectorised the usual structure-of-arrays way
// (one vertex per lane) it needs 12 gathers an influence, and gathers are slow on AMD cores: in a
// prototype on the development machine (AMD EPYC, Zen 5; 4 random influences a vertex, 10,475
// vertices, one core) that loop ran at 85 M vertices/s, plain scalar code at 125-170 M, and this
// kernel at 400-430 M (530-550 M on the SMPL-X body in bench_skinning). The AVX-512
// kernel holds M in one 16-lane register, so each palette entry is one aligned 64-byte load: the
// C blends are C fused multiply-adds, the transform is one multiply by
// (x, x, x, x, y, y, y, y, z, z, z, z, 1, 1, 1, 1) and a sum of the four column quarters. The
// streams stay structure-of-arrays (positions, entries, weights, rows apart, each read in order)
// and grouping by C keeps the blend loop's trip count fixed. The portable kernel writes the same
// maths with GLM; it is what builds without AVX-512 run, and the tests hold the two together.
//
// Ownership: the caller owns every array; a kernel reads the palette and the group's streams and
// writes only the rows of its vertices, so blocks of one frame can run on different threads.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>

#if defined(__AVX512F__) && defined(__AVX512VL__) && defined(__AVX512DQ__)
#include <immintrin.h>
#define ODYSSEY_SKINNING_AVX512 1
#endif

namespace odyssey::skinning::kernel {

// One skinning matrix, alone on a 64-byte cache line so that a kernel reads it in one load.
struct alignas(64) PaletteEntry {
  glm::mat4 matrix;
};
static_assert(sizeof(PaletteEntry) == 16 * sizeof(float), "a palette entry is 16 floats");

// A group's streams (lbs.cpp builds them): entry v of each stream belongs to vertex v of the
// group, and a vertex's C influences sit next to each other.
struct GroupStreams {
  const glm::vec4* rest_positions = nullptr;  // (x, y, z, 1), mesh space
  const glm::vec4* rest_normals = nullptr;    // (nx, ny, nz, 0); read only when normals are written
  const std::uint32_t* palette_entries = nullptr;  // C per vertex
  const float* weights = nullptr;                  // C per vertex
  const std::uint32_t* rows = nullptr;             // output row of each vertex
};

// A normal of squared length below this is the zero vector (normals.h): dividing by the square
// root of it keeps it zero instead of making it NaN.
inline constexpr float kSmallestSquaredNormal = std::numeric_limits<float>::min();

template <int C, bool Normals>
void skin_block_portable(const PaletteEntry* palette, const GroupStreams& group, std::size_t begin, std::size_t end,
                         float* positions, float* normals) {
  for (std::size_t v = begin; v < end; ++v) {
    const std::uint32_t* entries = group.palette_entries + C * v;
    const float* weights = group.weights + C * v;
    glm::mat4 blended = palette[entries[0]].matrix * weights[0];
    for (int k = 1; k < C; ++k) blended += palette[entries[k]].matrix * weights[k];
    const std::size_t out = 3 * std::size_t(group.rows[v]);
    const glm::vec4 position = blended * group.rest_positions[v];
    positions[out] = position.x, positions[out + 1] = position.y, positions[out + 2] = position.z;
    if constexpr (Normals) {
      const glm::vec3 normal(blended * group.rest_normals[v]);
      const glm::vec3 unit = normal / std::sqrt(std::max(glm::dot(normal, normal), kSmallestSquaredNormal));
      normals[out] = unit.x, normals[out + 1] = unit.y, normals[out + 2] = unit.z;
    }
  }
}

#ifdef ODYSSEY_SKINNING_AVX512
// (a, b, c, d) -> (a, a, a, a, b, b, b, b, c, c, c, c, d, d, d, d): each coordinate meets the
// column of M it multiplies.
inline __m512 spread_coordinates(const glm::vec4& point) {
  const __m512i spread = _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
  return _mm512_permutexvar_ps(spread, _mm512_zextps128_ps512(_mm_loadu_ps(&point.x)));
}

// The sum of the four 4-lane quarters: column 0 x + column 1 y + column 2 z + column 3 w.
inline __m128 sum_quarters(__m512 products) {
  const __m256 halves = _mm256_add_ps(_mm512_castps512_ps256(products), _mm512_extractf32x8_ps(products, 1));
  return _mm_add_ps(_mm256_castps256_ps128(halves), _mm256_extractf128_ps(halves, 1));
}

template <int C, bool Normals>
void skin_block_avx512(const PaletteEntry* palette, const GroupStreams& group, std::size_t begin, std::size_t end,
                       float* positions, float* normals) {
  const float* __restrict matrices = &palette[0].matrix[0][0];
  constexpr __mmask8 kXyz = 0b0111;
  for (std::size_t v = begin; v < end; ++v) {
    const std::uint32_t* __restrict entries = group.palette_entries + C * v;
    const float* __restrict weights = group.weights + C * v;
    __m512 blended = _mm512_mul_ps(_mm512_set1_ps(weights[0]), _mm512_load_ps(matrices + 16 * std::size_t(entries[0])));
    for (int k = 1; k < C; ++k) {
      blended = _mm512_fmadd_ps(_mm512_set1_ps(weights[k]), _mm512_load_ps(matrices + 16 * std::size_t(entries[k])),
                                blended);
    }
    const std::size_t out = 3 * std::size_t(group.rows[v]);
    _mm_mask_storeu_ps(positions + out, kXyz,
                       sum_quarters(_mm512_mul_ps(blended, spread_coordinates(group.rest_positions[v]))));
    if constexpr (Normals) {
      // 1 / |n| from the 14-bit reciprocal square root and one Newton step,
      // r <- r (3 - s r^2) / 2, which leaves a relative error of about 1e-8 before rounding.
      const __m128 normal = sum_quarters(_mm512_mul_ps(blended, spread_coordinates(group.rest_normals[v])));
      const __m128 squared = _mm_max_ps(_mm_dp_ps(normal, normal, 0x7f), _mm_set1_ps(kSmallestSquaredNormal));
      const __m128 estimate = _mm_rsqrt14_ps(squared);
      const __m128 correction = _mm_fnmadd_ps(_mm_mul_ps(squared, estimate), estimate, _mm_set1_ps(3.0f));
      const __m128 inverse_length = _mm_mul_ps(_mm_mul_ps(_mm_set1_ps(0.5f), estimate), correction);
      _mm_mask_storeu_ps(normals + out, kXyz, _mm_mul_ps(normal, inverse_length));
    }
  }
}
#endif

// The kernel this build runs.
template <int C, bool Normals>
void skin_block(const PaletteEntry* palette, const GroupStreams& group, std::size_t begin, std::size_t end,
                float* positions, float* normals) {
#ifdef ODYSSEY_SKINNING_AVX512
  skin_block_avx512<C, Normals>(palette, group, begin, end, positions, normals);
#else
  skin_block_portable<C, Normals>(palette, group, begin, end, positions, normals);
#endif
}

}  // namespace odyssey::skinning::kernel
