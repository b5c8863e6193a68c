#pragma once
/// @file renderer.h
/// Renders the Lunar terrain through a pinhole camera: one ray per pixel centre, intersected exactly with the
/// frame's level-of-detail heightfield, lunar-Lambert shading, hard cast shadows, black sky.
///
/// How a frame is made (and why it is fast and exact):
///  1. The terrain is baked on a global lattice per LOD level k (spacing 2^k / 64 m) in 64x64-sample
///     chunks that are cached between frames (a multi-resolution heightfield along the ground track):
///     consecutive frames share almost all their chunks, so only the newly seen ground is evaluated
///     procedurally.
///  2. A continuous LOD field l(x, y) = log2(footprint of one pixel at distance |(x, y) - camera|) picks,
///     for each ground point, a blend of the two nearest levels (geomorphing). The rendered surface of a
///     frame is therefore one continuous function z = H(x, y): every pixel is the exact pinhole projection of
///     that surface.
///  3. Primary rays march with the surface's Lipschitz bound plus empty-space skipping: each LOD level keeps
///     a max pyramid of its heights (blocks of 2 ... 512 lattice cells, folded with the next coarser level so
///     it bounds the blended surface), and a ray above the bound of the block it is in jumps to the block
///     exit or to the bound plane. The crossing is bracketed and refined by regula falsi to < 0.1 mm in
///     height. Cast shadows come from a horizon sweep of each level toward the Sun
///     (every lattice sample marches toward the Sun at once, carrying the running shadow height), seeded from
///     the next coarser level so distant ridges cast shadows into the detailed area.
///  4. Chunks are baked (LunarTerrain::sampleGrid, per feature), assembled and bounded in parallel; rows are
///     traced in parallel (std::thread). Results do not depend on the thread count.

#include <cstdint>
#include <memory>
#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/render/photometry.h"
#include "planetary_vo/render/terrain.h"

namespace planetary_vo::render {

struct RenderSettings {
  /// The camera the images are taken with. With lens distortion, each pixel's ray goes through the distortion
  /// (pixel -> undistorted -> bearing): the image is what the real lens shows.
  PinholeCamera camera = PinholeCamera::fromFieldOfView(1024, 1024, 60.0);
  Eigen::Vector3d sun_direction = sunDirection(12.0, 250.0);  ///< unit, world, toward the Sun
  /// Gray level of flat, average-albedo terrain seen from nadir (exposure); slopes facing the Sun are
  /// brighter.
  double flat_gray_level = 85.0;
  double noise_sigma_dn = 0.0;  ///< read noise (DN); shot noise scales with it. 0 = noiseless
  uint64_t noise_seed = 0;
  /// Also output the scene's reflectance factor I/F per pixel (the input of a sensor model,
  /// sensors/camera_sensor.h).
  bool output_reflectance = false;
  int num_threads = 0;         ///< 0 = std::thread::hardware_concurrency()
  double lod_bias = 0.0;       ///< +1 = half the detail (coarser lattice), -1 = twice
  size_t cache_chunks = 2500;  ///< 64x64-sample chunks kept between frames (32 KiB each)
};

struct RenderStats {
  double setup_ms = 0.0;     ///< region, chunk baking, level assembly (sum of the next three)
  double region_ms = 0.0;    ///< view footprint and LOD levels
  double bake_ms = 0.0;      ///< procedural evaluation of the chunks missing from the cache
  double assemble_ms = 0.0;  ///< level windows from chunks, Lipschitz bound
  double shadow_ms = 0.0;    ///< horizon sweeps
  double trace_ms = 0.0;     ///< ray casting and shading
  int chunks_baked = 0;      ///< chunks evaluated procedurally for this frame (not from the cache)
  int chunks_used = 0;
  int levels = 0;
  double mean_ray_steps = 0.0;
  double lipschitz = 0.0;  ///< slope bound of the frame surface used by the ray march
};

struct RenderOutput {
  cv::Mat1b image;   ///< 8-bit gray
  cv::Mat1f depth;   ///< z-depth along the optical axis (m); 0 where the ray sees no terrain
  cv::Mat1b shadow;  ///< 255 where the visible point is in cast or attached shadow
  /// Reflectance factor I/F of the point each pixel sees (0 in shadow and where there is no terrain),
  /// noiseless; only when RenderSettings::output_reflectance.
  cv::Mat1f reflectance;
  RenderStats stats;
};

class Renderer {
 public:
  Renderer(std::shared_ptr<const LunarTerrain> terrain, const RenderSettings& settings);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Renders the view of the camera at T_world_cam. `frame_index` only seeds the sensor noise. Deterministic:
  /// the same terrain, settings and pose give the same image whatever the thread count or cache state.
  RenderOutput render(const Pose& T_world_cam, uint64_t frame_index = 0);

  const RenderSettings& settings() const;
  const LunarTerrain& terrain() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Intersects a ray with the procedural terrain itself (evaluated at footprint `lod_m`, no baking): distance
/// along the unit direction to the first crossing, refined to < 0.1 mm, or nothing within max_range_m. For
/// the altimeter.
std::optional<double> castRayOnTerrain(const LunarTerrain& terrain, const Eigen::Vector3d& origin,
                                       const Eigen::Vector3d& direction, double lod_m, double max_range_m);

}  // namespace planetary_vo::render
