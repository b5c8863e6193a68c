#include "planetary_vo/render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <thread>
#include <tuple>
#include <vector>

#include "noise.h"

namespace planetary_vo::render {

namespace {

constexpr double kBaseSpacing = 1.0 / 64.0;  // lattice spacing of level 0 (m)
constexpr int kChunk = 64;                   // samples per chunk side
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kBlockShift = 1;  // finest blocks of 2x2 lattice cells for the empty-space bound
constexpr int kBlock = 1 << kBlockShift;
constexpr float kNoBound = std::numeric_limits<float>::infinity();
constexpr int kMipLevels = 8;  // bound blocks of 2 ... 512 lattice cells

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Runs fn(i) for i in [0, n) on `threads` threads, handing out indices dynamically (balanced row bands).
template <typename F>
void parallelFor(int n, int threads, F&& fn) {
  threads = std::max(1, std::min(threads, n));
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int i = next++; i < n; i = next++) fn(i);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& th : pool) th.join();
}

struct Chunk {
  std::vector<float> height, albedo;
  uint64_t last_used = 0;
};

/// One LOD level of the current frame: a dense window of the global lattice of spacing s.
struct Level {
  int k = 0;
  double s = 1.0, inv_s = 1.0;
  int64_t i0 = 0, j0 = 0;  // global lattice index of sample (0, 0)
  int nx = 0, ny = 0;
  std::vector<float> h, a, sh;  // height, albedo, shadow-top height
  // Upper bound of the frame surface over each kBlock x kBlock-cell block of this level's global lattice
  // (block b covers lattice indices [kBlock b, kBlock b + kBlock]), valid wherever floor(lod) is this level:
  // lets primary rays skip whole blocks they pass above (conservative empty-space skipping).
  int64_t bx0 = 0, by0 = 0;
  int nbx = 0, nby = 0;
  std::vector<float> bound;
  // Max pyramid of `bound`: pyramid[m] holds blocks of kBlock * 2^(m+1) cells (max of their 4 children), so
  // rays high above the ground skip tens of metres per step instead of one small block.
  struct Mip {
    int64_t bx0 = 0, by0 = 0;
    int nbx = 0, nby = 0;
    std::vector<float> v;
  };
  std::vector<Mip> pyramid;

  bool locate(double x, double y, int* idx, double* fu, double* fv) const {
    const double u = x * inv_s - static_cast<double>(i0), v = y * inv_s - static_cast<double>(j0);
    if (!(u >= 0.0 && v >= 0.0 && u < nx - 1 && v < ny - 1)) return false;
    const int iu = static_cast<int>(u), iv = static_cast<int>(v);
    *idx = iv * nx + iu;
    *fu = u - iu, *fv = v - iv;
    return true;
  }
  static double bilerp(const std::vector<float>& f, int idx, int nx, double fu, double fv) {
    const double a = f[idx] + fu * (f[idx + 1] - f[idx]);
    const double b = f[idx + nx] + fu * (f[idx + nx + 1] - f[idx + nx]);
    return a + fv * (b - a);
  }
  double sampleField(const std::vector<float>& f, double x, double y) const {
    int idx;
    double fu, fv;
    return locate(x, y, &idx, &fu, &fv) ? bilerp(f, idx, nx, fu, fv) : kNaN;
  }
};

}  // namespace

struct Renderer::Impl {
  std::shared_ptr<const LunarTerrain> terrain;
  RenderSettings settings;
  int threads = 1;
  std::map<std::tuple<int, int64_t, int64_t>, Chunk> cache;
  uint64_t frame_counter = 0;
  // Unit bearing of every pixel through the lens distortion (row-major); empty without distortion, where the
  // pinhole bearing is computed on the fly as it always was (so ideal images stay bit-identical).
  std::vector<Eigen::Vector3d> distorted_bearings;

  Eigen::Vector3d pixelBearing(int col, int row) const {
    if (distorted_bearings.empty()) return settings.camera.pixelToBearing(Eigen::Vector2d(col, row));
    return distorted_bearings[static_cast<size_t>(row) * settings.camera.width() + col];
  }

  // Per-frame state.
  std::vector<Level> levels;  // index 0 = finest (kmin)
  int kmin = 0, kmax = 0;
  Eigen::Vector3d cam = Eigen::Vector3d::Zero();
  double ifov = 1.0, z_ref = 0.0, dz2 = 0.0;
  double lipschitz = 1.0, zhi = 0.0, zlo = 0.0;
  double bias = 0.0, lod_offset = 0.0;

  /// Continuous LOD of the ground point (x, y): log2 of the pixel footprint there, in lattice levels.
  double lodAt(double x, double y) const {
    const double dx = x - cam.x(), dy = y - cam.y();
    // log2(distance * ifov / base) + bias, without the square root (this runs once per ray step).
    // Single precision: the LOD only chooses the blend of two lattices; its rounding (1e-7 of a level)
    // changes the surface by far less than the 0.1 mm crossing tolerance, and log2f is several times faster.
    const double l =
        0.5 * static_cast<double>(std::log2(static_cast<float>(dx * dx + dy * dy + dz2))) + lod_offset;
    return std::clamp(l, static_cast<double>(kmin), static_cast<double>(kmax));
  }

  /// Blended value of field `which` (0 height, 1 albedo, 2 shadow top) at (x, y); NaN outside the frame
  /// region.
  double field(int which, double x, double y, double l) const {
    int k = static_cast<int>(std::floor(l));
    double f = l - k;
    if (k >= kmax) k = kmax, f = 0.0;
    int li = k - kmin;
    auto pick = [&](const Level& L) -> const std::vector<float>& {
      return which == 0 ? L.h : which == 1 ? L.a : L.sh;
    };
    // Finer levels only cover where they are needed; fall back to coarser ones near the region's edge.
    double v0 = kNaN;
    for (; li < static_cast<int>(levels.size()); ++li, f = 0.0) {
      v0 = levels[li].sampleField(pick(levels[li]), x, y);
      if (!std::isnan(v0)) break;
    }
    if (std::isnan(v0) || f <= 0.0 || li + 1 >= static_cast<int>(levels.size())) return v0;
    const double v1 = levels[li + 1].sampleField(pick(levels[li + 1]), x, y);
    return std::isnan(v1) ? v0 : v0 + f * (v1 - v0);
  }
  double height(double x, double y) const { return field(0, x, y, lodAt(x, y)); }

  // Horizontal distance from the camera at which floor(lod) reaches level index i (radius_to_level[i]).
  std::vector<double> radius_to_level;
  std::vector<std::vector<float>> raw_bounds;  // scratch of buildBlockBounds, kept for its capacity

  void buildBlockBounds();
  void setupFrame(const Pose& T, RenderStats* stats);
  void bakeLevels(RenderStats* stats);
  void sweepShadows();
  void trace(const Pose& T, RenderOutput* out, uint64_t frame_index);
};

void Renderer::Impl::setupFrame(const Pose& T, RenderStats* stats) {
  const PinholeCamera& camera = settings.camera;
  cam = T.translation();
  ifov = 1.0 / camera.fx();
  bias = settings.lod_bias;
  lod_offset = std::log2(ifov / kBaseSpacing) + bias;
  const LunarTerrain& ter = *terrain;
  // Procedural relief bounds: crater floors go down ~0.2 D, rims and blocks rise ~0.05 D, plus roughness.
  const double relief_down = ter.maxProceduralReliefM();
  const double relief_up = 0.25 * relief_down;

  // Directions of rays along the image border and through its centre.
  std::vector<Eigen::Vector3d> dirs;
  const int W = camera.width(), H = camera.height();
  for (int i = 0; i <= 16; ++i) {
    const double u = (W - 1) * i / 16.0, v = (H - 1) * i / 16.0;
    for (const Eigen::Vector2d& px : {Eigen::Vector2d(u, 0), Eigen::Vector2d(u, H - 1), Eigen::Vector2d(0, v),
                                      Eigen::Vector2d(W - 1, v), Eigen::Vector2d(0.5 * W, 0.5 * H)})
      dirs.push_back(T.linear() * (camera.hasDistortion() ? camera.distortedPixelToBearing(px)
                                                          : camera.pixelToBearing(px)));
  }
  // Footprint box between two height planes; iterate once so the planes come from the DEM under the
  // footprint.
  const double nadir_dem = ter.demHeight(cam.x(), cam.y());
  double lo = nadir_dem - relief_down, hi = nadir_dem + relief_up;
  double bx0 = 0, bx1 = 0, by0 = 0, by1 = 0;
  for (int iter = 0; iter < 2; ++iter) {
    bx0 = by0 = 1e18, bx1 = by1 = -1e18;
    const double max_range = 40.0 * std::max(cam.z() - lo, 10.0);
    for (const Eigen::Vector3d& d : dirs) {
      for (double z : {lo, hi}) {
        double t = max_range;
        if (d.z() < -1e-9 && cam.z() > z) t = std::min(max_range, (cam.z() - z) / -d.z());
        if (cam.z() <= z) t = 0.0;
        const Eigen::Vector3d p = cam + t * d;
        bx0 = std::min(bx0, p.x()), bx1 = std::max(bx1, p.x()), by0 = std::min(by0, p.y()),
        by1 = std::max(by1, p.y());
      }
    }
    double dmin = 1e18, dmax = -1e18;
    const double step = std::max({(bx1 - bx0) / 24, (by1 - by0) / 24, 20.0});
    for (double x = bx0; x <= bx1 + step; x += step)
      for (double y = by0; y <= by1 + step; y += step) {
        const double h = ter.demHeight(x, y);
        dmin = std::min(dmin, h), dmax = std::max(dmax, h);
      }
    lo = dmin - relief_down - 20.0, hi = dmax + relief_up + 20.0;  // +-20 m: DEM extrema between probes
  }
  zlo = lo, zhi = hi;
  // Extension toward the Sun: terrain up to (hi - lo) / tan(elevation) away can cast shadows into the view.
  // Only coarse levels (<= ~384 samples across the extension) cover it: distant casters need no fine detail,
  // and the fine levels take their incoming shadow from the coarser ones.
  const Eigen::Vector3d& sun = settings.sun_direction;
  const double sun_h = std::hypot(sun.x(), sun.y());
  double ex0 = bx0, ex1 = bx1, ey0 = by0, ey1 = by1, ext_len = 0.0;
  if (sun_h > 1e-6 && sun.z() > 0) {
    ext_len = std::min((hi - lo) * sun_h / std::max(sun.z(), 1e-3), 8000.0);
    const double ex = ext_len * sun.x() / sun_h, ey = ext_len * sun.y() / sun_h;
    ex0 = std::min(bx0, bx0 + ex), ex1 = std::max(bx1, bx1 + ex), ey0 = std::min(by0, by0 + ey),
    ey1 = std::max(by1, by1 + ey);
  }

  // LOD range over the view box: footprint is distance * ifov, distances measured to the plane z_ref (the DEM
  // under the camera: the LOD field must depend on (x, y) only, and a conservative plane would over-refine).
  z_ref = std::min(nadir_dem, cam.z() - 1.0);
  const double dz = std::max(cam.z() - z_ref, 0.5);
  dz2 = dz * dz;
  const double far_dx = std::max(std::abs(bx0 - cam.x()), std::abs(bx1 - cam.x()));
  const double far_dy = std::max(std::abs(by0 - cam.y()), std::abs(by1 - cam.y()));
  const double far = std::sqrt(far_dx * far_dx + far_dy * far_dy + dz2);
  const double near_dx = std::max({bx0 - cam.x(), cam.x() - bx1, 0.0}),
               near_dy = std::max({by0 - cam.y(), cam.y() - by1, 0.0});
  const double near = std::sqrt(near_dx * near_dx + near_dy * near_dy + dz2);
  kmin = std::max(0, static_cast<int>(std::floor(std::log2(near * ifov / kBaseSpacing) + bias)));
  kmax = std::max(kmin, static_cast<int>(std::ceil(std::log2(far * ifov / kBaseSpacing) + bias)));
  const int k_ext =
      static_cast<int>(std::ceil(std::log2(std::max(ext_len / 384.0, kBaseSpacing) / kBaseSpacing)));
  kmax = std::min(std::max(kmax, k_ext), kmin + 16);

  // Keep the previous frame's Level objects: their buffers are reused (no per-frame allocation and page
  // faults of tens of MB at 1024x1024); every field is overwritten below or in bakeLevels.
  levels.resize(kmax - kmin + 1);
  for (int k = kmax; k >= kmin; --k) {
    Level& L = levels[k - kmin];
    L.k = k;
    L.s = kBaseSpacing * std::ldexp(1.0, k);
    L.inv_s = 1.0 / L.s;  // exact: a power of two
    const bool covers_extension = k >= k_ext || k == kmax;
    double x0 = covers_extension ? ex0 : bx0, x1 = covers_extension ? ex1 : bx1;
    double y0 = covers_extension ? ey0 : by0, y1 = covers_extension ? ey1 : by1;
    if (k < kmax) {
      // Level k is used where lod < k + 1, i.e. within distance D_k of the camera.
      const double dk = kBaseSpacing * std::ldexp(1.0, k + 1) * std::exp2(-bias) / ifov;
      const double r = dk > dz ? std::sqrt(dk * dk - dz2) : 0.0;
      x0 = std::max(x0, cam.x() - r), x1 = std::min(x1, cam.x() + r);
      y0 = std::max(y0, cam.y() - r), y1 = std::min(y1, cam.y() + r);
      if (x1 < x0) x1 = x0 = std::clamp(cam.x(), bx0, bx1);
      if (y1 < y0) y1 = y0 = std::clamp(cam.y(), by0, by1);
    }
    const int margin = 3;  // bilinear + normal stencil
    L.i0 = static_cast<int64_t>(std::floor(x0 / L.s)) - margin;
    L.j0 = static_cast<int64_t>(std::floor(y0 / L.s)) - margin;
    L.nx = static_cast<int>(std::ceil(x1 / L.s) - L.i0) + margin + 1;
    L.ny = static_cast<int>(std::ceil(y1 / L.s) - L.j0) + margin + 1;
    if (static_cast<double>(L.nx) * L.ny > 3.0e7)
      throw std::runtime_error("render: LOD level too large (" + std::to_string(L.nx) + "x" +
                               std::to_string(L.ny) + " samples); raise lod_bias or lower the resolution");
  }
  stats->levels = static_cast<int>(levels.size());
  // floor(lod) = k from distance base * 2^(k - bias) / ifov on (lodAt's metric includes the height dz).
  radius_to_level.assign(levels.size() + 1, std::numeric_limits<double>::infinity());
  for (size_t i = 1; i < levels.size(); ++i) {
    const double dist =
        kBaseSpacing * std::exp2(static_cast<double>(kmin + static_cast<int>(i)) - bias) / ifov;
    radius_to_level[i] = std::sqrt(std::max(0.0, dist * dist - dz2));
  }
}

void Renderer::Impl::bakeLevels(RenderStats* stats) {
  ++frame_counter;
  const LunarTerrain& ter = *terrain;
  // Collect the chunks of every level, bake the missing ones in parallel.
  struct Need {
    int k;
    int64_t ci, cj;
    Chunk* chunk;
  };
  std::vector<Need> needs, missing;
  auto floorDiv = [](int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); };
  for (const Level& L : levels) {
    for (int64_t cj = floorDiv(L.j0, kChunk); cj <= floorDiv(L.j0 + L.ny - 1, kChunk); ++cj)
      for (int64_t ci = floorDiv(L.i0, kChunk); ci <= floorDiv(L.i0 + L.nx - 1, kChunk); ++ci) {
        auto [it, inserted] = cache.try_emplace({L.k, ci, cj});
        it->second.last_used = frame_counter;
        needs.push_back({L.k, ci, cj, &it->second});
        if (inserted) missing.push_back(needs.back());
      }
  }
  auto t_bake = Clock::now();
  parallelFor(static_cast<int>(missing.size()), threads, [&](int m) {
    const Need& n = missing[m];
    const double s = kBaseSpacing * std::ldexp(1.0, n.k);
    Chunk& c = *n.chunk;
    c.height.resize(kChunk * kChunk);
    c.albedo.resize(kChunk * kChunk);
    ter.sampleGrid(n.ci * kChunk, n.cj * kChunk, kChunk, kChunk, s, s, c.height.data(), c.albedo.data());
  });
  stats->bake_ms = msSince(t_bake);
  stats->chunks_baked = static_cast<int>(missing.size());
  stats->chunks_used = static_cast<int>(needs.size());

  // Assemble the dense level windows: chunks cover their level's window completely and write disjoint parts
  // of it, so they are copied in parallel into uninitialised storage.
  for (Level& L : levels) {
    L.h.resize(static_cast<size_t>(L.nx) * L.ny);
    L.a.resize(L.h.size());
  }
  std::vector<Level*> level_of_k(kmax - kmin + 1);
  for (Level& L : levels) level_of_k[L.k - kmin] = &L;
  parallelFor(static_cast<int>(needs.size()), threads, [&](int m) {
    const Need& n = needs[m];
    Level& L = *level_of_k[n.k - kmin];
    const int64_t x_first = std::max<int64_t>(0, n.ci * kChunk - L.i0);
    const int64_t x_end = std::min<int64_t>(L.nx, n.ci * kChunk + kChunk - L.i0);
    for (int j = 0; j < kChunk; ++j) {
      const int64_t y = n.cj * kChunk + j - L.j0;
      if (y < 0 || y >= L.ny) continue;
      const int64_t src = j * kChunk + (x_first + L.i0 - n.ci * kChunk);
      std::copy(n.chunk->height.begin() + src, n.chunk->height.begin() + src + (x_end - x_first),
                L.h.begin() + y * L.nx + x_first);
      std::copy(n.chunk->albedo.begin() + src, n.chunk->albedo.begin() + src + (x_end - x_first),
                L.a.begin() + y * L.nx + x_first);
    }
  });
  // Evict the least recently used chunks beyond the budget (never those of this frame).
  if (cache.size() > settings.cache_chunks) {
    std::vector<std::pair<uint64_t, std::tuple<int, int64_t, int64_t>>> order;
    for (const auto& [key, c] : cache)
      if (c.last_used != frame_counter) order.push_back({c.last_used, key});
    std::sort(order.begin(), order.end());
    const size_t excess = cache.size() - settings.cache_chunks;
    for (size_t i = 0; i < std::min(excess, order.size()); ++i) cache.erase(order[i].second);
  }

  // Lipschitz bound of the frame surface H(x, y): steepest lattice slope of any level plus the geomorphing
  // term (h_{k+1} - h_k) * dl/dx, with |dl/dx| <= 1 / (ln 2 * distance).
  // Computed over row bands of every level in parallel (it touches every sample of the frame).
  struct Band {
    int li, j0, j1;
    double slope = 0.0, morph = 0.0, hmax = -1e18, hmin = 1e18;
  };
  std::vector<Band> bands;
  for (int li = 0; li < static_cast<int>(levels.size()); ++li)
    for (int j = 0; j < levels[li].ny; j += 64) bands.push_back({li, j, std::min(j + 64, levels[li].ny)});
  parallelFor(static_cast<int>(bands.size()), threads, [&](int bi) {
    Band& B = bands[bi];
    const Level& L = levels[B.li];
    float m = 0.f, lo = std::numeric_limits<float>::max(), hi = -lo;
    for (int j = B.j0; j < B.j1; ++j) {
      const float* r0 = &L.h[static_cast<size_t>(j) * L.nx];
      for (int i = 0; i < L.nx; ++i) lo = std::min(lo, r0[i]), hi = std::max(hi, r0[i]);
      if (j + 1 >= L.ny) continue;
      const float* r1 = r0 + L.nx;
      for (int i = 0; i + 1 < L.nx; ++i)
        m = std::max({m, std::abs(r0[i + 1] - r0[i]), std::abs(r1[i] - r0[i]), std::abs(r1[i + 1] - r0[i])});
    }
    B.slope = m / L.s, B.hmin = lo, B.hmax = hi;
    if (B.li + 1 < static_cast<int>(levels.size())) {
      const Level& C = levels[B.li + 1];
      for (int j = B.j0 + (4 - B.j0 % 4) % 4; j < B.j1; j += 4)
        for (int i = 0; i < L.nx; i += 4) {
          const double v = C.sampleField(C.h, (L.i0 + i) * L.s, (L.j0 + j) * L.s);
          if (!std::isnan(v)) B.morph = std::max(B.morph, std::abs(v - L.h[j * L.nx + i]));
        }
    }
  });
  double slope = 0.0, morph = 0.0, hmax = -1e18, hmin = 1e18;
  for (const Band& B : bands)
    slope = std::max(slope, B.slope), morph = std::max(morph, B.morph), hmax = std::max(hmax, B.hmax),
    hmin = std::min(hmin, B.hmin);
  lipschitz = 1.1 * (slope + (morph + 0.1) / (std::log(2.0) * std::sqrt(dz2))) + 1e-3;
  zhi = hmax, zlo = hmin;
  stats->lipschitz = lipschitz;
}

void Renderer::Impl::buildBlockBounds() {
  // Per level: max of the lattice heights over each block (the bilinear surface never exceeds its corners).
  const int nl = static_cast<int>(levels.size());
  parallelFor(nl, threads, [&](int li) {
    Level& L = levels[li];
    L.bx0 = L.i0 >> kBlockShift, L.by0 = L.j0 >> kBlockShift;  // arithmetic shift = floor division
    L.nbx = static_cast<int>(((L.i0 + L.nx - 1) >> kBlockShift) - L.bx0 + 1);
    L.nby = static_cast<int>(((L.j0 + L.ny - 1) >> kBlockShift) - L.by0 + 1);
    L.bound.assign(static_cast<size_t>(L.nbx) * L.nby, -kNoBound);
    for (int j = 0; j < L.ny; ++j) {
      // Sample (i, j) is a corner of blocks floor(g / 8) and, on a block edge, floor((g - 1) / 8).
      const int64_t gj = L.j0 + j;
      for (int64_t bj = (gj - 1) >> kBlockShift; bj <= gj >> kBlockShift; ++bj) {
        if (bj < L.by0 || bj >= L.by0 + L.nby) continue;
        float* row = &L.bound[(bj - L.by0) * L.nbx];
        const float* h = &L.h[static_cast<size_t>(j) * L.nx];
        for (int i = 0; i < L.nx; ++i) {
          const int64_t gi = L.i0 + i;
          const int64_t b1 = (gi >> kBlockShift) - L.bx0, b0 = ((gi - 1) >> kBlockShift) - L.bx0;
          if (b1 < L.nbx) row[b1] = std::max(row[b1], h[i]);
          if (b0 >= 0 && b0 != b1) row[b0] = std::max(row[b0], h[i]);
        }
      }
    }
  });
  // A point whose floor(lod) is level li blends li with li + 1 (raw maxima suffice when the block lies inside
  // li's window: li + 1 is then used where it exists, else ignored); near the window edge it may fall back
  // to li + 1 alone and beyond, which li + 1's own final bound covers. The coarsest level has nothing to fall
  // back to (the ray leaves the terrain there): no skipping over its partial blocks.
  raw_bounds.resize(nl);
  std::vector<std::vector<float>>& raw = raw_bounds;
  for (int li = 0; li < nl; ++li) raw[li] = levels[li].bound;  // reuses capacity
  for (int li = nl - 1; li >= 0; --li) {
    Level& L = levels[li];
    const Level* C = li + 1 < nl ? &levels[li + 1] : nullptr;
    for (int bj = 0; bj < L.nby; ++bj)
      for (int bi = 0; bi < L.nbx; ++bi) {
        const int64_t gbi = L.bx0 + bi, gbj = L.by0 + bj;
        // Block indices are negative west and south of the origin: multiplied, not left-shifted (a left shift
        // of a negative value is undefined before C++20; UBSan, issue 12).
        const bool inside = gbi * kBlock >= L.i0 && gbj * kBlock >= L.j0 &&
                            (gbi + 1) * kBlock <= L.i0 + L.nx - 1 && (gbj + 1) * kBlock <= L.j0 + L.ny - 1;
        float& out = L.bound[bj * L.nbx + bi];
        const float own = raw[li][bj * L.nbx + bi];
        if (!C) {
          out = inside ? own : kNoBound;
          continue;
        }
        const int64_t pi = (gbi >> 1) - C->bx0, pj = (gbj >> 1) - C->by0;
        const bool parent_ok = pi >= 0 && pj >= 0 && pi < C->nbx && pj < C->nby;
        if (inside)
          out = std::max(own, parent_ok ? raw[li + 1][pj * C->nbx + pi] : -kNoBound);
        else
          out = std::max(own, parent_ok ? C->bound[pj * C->nbx + pi] : kNoBound);
      }
  }
  parallelFor(nl, threads, [&](int li) {
    Level& L = levels[li];
    L.pyramid.resize(kMipLevels);
    int64_t bx0 = L.bx0, by0 = L.by0;
    int nbx = L.nbx, nby = L.nby;
    const std::vector<float>* child = &L.bound;
    for (int m = 0; m < kMipLevels; ++m) {
      Level::Mip& P = L.pyramid[m];
      P.bx0 = bx0 >> 1, P.by0 = by0 >> 1;
      P.nbx = static_cast<int>(((bx0 + nbx - 1) >> 1) - P.bx0 + 1);
      P.nby = static_cast<int>(((by0 + nby - 1) >> 1) - P.by0 + 1);
      P.v.assign(static_cast<size_t>(P.nbx) * P.nby, -kNoBound);
      for (int j = 0; j < nby; ++j)
        for (int i = 0; i < nbx; ++i) {
          float& b = P.v[(((by0 + j) >> 1) - P.by0) * P.nbx + (((bx0 + i) >> 1) - P.bx0)];
          b = std::max(b, (*child)[j * nbx + i]);
        }
      bx0 = P.bx0, by0 = P.by0, nbx = P.nbx, nby = P.nby;
      child = &P.v;
    }
  });
}

void Renderer::Impl::sweepShadows() {
  const Eigen::Vector3d& sun = settings.sun_direction;
  const double sun_h = std::hypot(sun.x(), sun.y());
  for (int li = static_cast<int>(levels.size()) - 1; li >= 0; --li) {
    Level& L = levels[li];
    const Level* C = li + 1 < static_cast<int>(levels.size()) ? &levels[li + 1] : nullptr;
    L.sh = L.h;
    if (sun.z() <= 0) {  // Sun below the horizon: everything dark
      for (float& v : L.sh) v = std::numeric_limits<float>::max();
      continue;
    }
    if (sun_h < 1e-9) continue;  // Sun at the zenith: no cast shadows
    const double tan_el = sun.z() / sun_h;
    // Shadow top carried in from the coarser level, relative to the surface (so LOD differences cast
    // nothing).
    auto fromCoarse = [&](double x, double y, double h_here) -> double {
      if (!C) return -1e30;
      const double sc = C->sampleField(C->sh, x, y), hc = C->sampleField(C->h, x, y);
      if (std::isnan(sc)) return -1e30;
      return std::isnan(h_here) ? sc : h_here + std::max(0.0, sc - hc);
    };
    const bool along_x = std::abs(sun.x()) >= std::abs(sun.y());
    // March lines perpendicular to the dominant sun axis, from the sunward side.
    const int n_outer = along_x ? L.nx : L.ny, n_inner = along_x ? L.ny : L.nx;
    const double main = along_x ? sun.x() : sun.y(), cross = along_x ? sun.y() : sun.x();
    const int dir = main > 0 ? 1 : -1;             // index step toward the Sun
    const double offset = cross / std::abs(main);  // inner-index shift per outer step toward the Sun
    const double drop = L.s * std::sqrt(1.0 + offset * offset) * tan_el;
    auto at = [&](int outer, int inner) -> float& {
      return along_x ? L.sh[inner * L.nx + outer] : L.sh[outer * L.nx + inner];
    };
    auto world = [&](double outer, double inner, double* x, double* y) {
      *x = (L.i0 + (along_x ? outer : inner)) * L.s;
      *y = (L.j0 + (along_x ? inner : outer)) * L.s;
    };
    const int first = dir > 0 ? n_outer - 1 : 0;
    for (int inner = 0; inner < n_inner; ++inner) {
      double x, y;
      world(first, inner, &x, &y);
      at(first, inner) =
          static_cast<float>(std::max<double>(at(first, inner), fromCoarse(x, y, at(first, inner))));
    }
    for (int outer = first - dir; outer >= 0 && outer < n_outer; outer -= dir) {
      const int src = outer + dir;
      for (int inner = 0; inner < n_inner; ++inner) {
        const double q = inner + offset;
        double s_src;
        if (q >= 0.0 && q <= n_inner - 1) {
          const int q0 = std::min(static_cast<int>(q), n_inner - 2);
          const double f = q - q0;
          s_src = at(src, q0) + f * (at(src, q0 + 1) - at(src, q0));
        } else {
          double x, y;
          world(src, q, &x, &y);
          s_src = fromCoarse(x, y, kNaN);
        }
        float& v = at(outer, inner);
        v = static_cast<float>(std::max<double>(v, s_src - drop));
      }
    }
  }
}

void Renderer::Impl::trace(const Pose& T, RenderOutput* out, uint64_t frame_index) {
  const PinholeCamera& camera = settings.camera;
  const int W = camera.width(), H = camera.height();
  out->image.create(H, W);
  out->depth.create(H, W);
  out->shadow.create(H, W);
  if (settings.output_reflectance) out->reflectance.create(H, W);
  const Eigen::Vector3d sun = settings.sun_direction.normalized();
  // Exposure: flat terrain of mean albedo seen from nadir maps to flat_gray_level.
  const double flat = lunarLambertReflectance(terrain->params().albedo, Eigen::Vector3d::UnitZ(), sun,
                                              Eigen::Vector3d::UnitZ());
  const double gain = settings.flat_gray_level / std::max(flat, 1e-6);
  std::atomic<long> total_steps{0};
  const Eigen::Matrix3d R = T.linear();

  parallelFor(H, threads, [&](int row) {
    long steps = 0;
    for (int col = 0; col < W; ++col) {
      const Eigen::Vector3d b = pixelBearing(col, row);  // unit, camera frame
      const Eigen::Vector3d d = R * b;
      const double dxy = std::hypot(d.x(), d.y());
      // Reciprocals for the block-exit tests of the march (divisions dominated its cost).
      const double inv_dx = 1.0 / d.x(), inv_dy = 1.0 / d.y(), inv_dz = 1.0 / d.z(), inv_dxy = 1.0 / dxy;
      double value = 0.0, depth = 0.0, reflectance = 0.0;
      bool shadowed = false;
      double t = 0.0;
      bool hit = false;
      if (cam.z() > zhi) t = d.z() < -1e-12 ? (cam.z() - zhi) / -d.z() : -1.0;
      if (t >= 0.0) {
        const double denom = lipschitz * dxy - d.z();
        double t_prev = t, g_prev = 0.0;
        for (int it = 0; it < 600; ++it, ++steps) {
          const Eigen::Vector3d p = cam + t * d;
          const double l = lodAt(p.x(), p.y());
          const double h = field(0, p.x(), p.y(), l);
          if (std::isnan(h) || p.z() < zlo - 1.0) break;  // left the frame region: no terrain
          const double g = p.z() - h;
          if (g < 0.0) {
            // Bracketed between t_prev (above) and t (below): Illinois regula falsi to < 0.1 mm.
            double ta = t_prev, ga = g_prev, tb = t, gb = g;
            int side = 0;
            for (int r = 0; r < 60; ++r, ++steps) {
              const double tm = (ta * gb - tb * ga) / (gb - ga);
              const Eigen::Vector3d pm = cam + tm * d;
              const double gm = pm.z() - field(0, pm.x(), pm.y(), lodAt(pm.x(), pm.y()));
              if (std::isnan(gm)) break;
              if (gm > 0) {
                ta = tm, ga = gm;
                if (side == 1) gb *= 0.5;
                side = 1;
              } else {
                tb = tm, gb = gm;
                if (side == -1) ga *= 0.5;
                side = -1;
              }
              t = tm;
              if (std::abs(gm) < 1e-4 || tb - ta < 1e-6) break;
            }
            hit = true;
            break;
          }
          if (g < 1e-4) {
            hit = true;
            break;
          }
          // Safe step: the surface cannot rise faster than the Lipschitz bound; up to 16x longer steps are
          // allowed while they move less than half a lattice cell sideways (a crossing is then caught by the
          // bracket). The global bound is loose (steep boulders somewhere in the frame), so near the surface
          // the pure safe step would converge geometrically; the longer step brackets the crossing at once.
          const double safe = g / denom;
          const double s_local = levels[std::min(static_cast<int>(l), kmax) - kmin].s;
          const double step =
              std::max(safe, std::min(16.0 * safe, dxy > 1e-9 ? 0.5 * s_local / dxy : 16.0 * safe));
          // Empty-space skipping: if the ray stays above the bound of the current block up to where it
          // leaves the block (or floor(lod) changes), it may jump there when that is farther than the safe
          // step. Exact: the bound is >= the surface everywhere on that segment.
          double skip_to = 0.0;
          const int li = std::min(static_cast<int>(l), kmax) - kmin;
          const Level& L = levels[li];
          {
            const int64_t gbi = static_cast<int64_t>(std::floor(p.x() * L.inv_s)) >> kBlockShift;
            const int64_t gbj = static_cast<int64_t>(std::floor(p.y() * L.inv_s)) >> kBlockShift;
            const double t_lod =
                dxy > 1e-12 ? radius_to_level[li + 1] * inv_dxy : std::numeric_limits<double>::infinity();
            // Climb the pyramid while the ray passes above the block containing p (a larger block has a
            // larger bound and a farther exit, so once one fails, all larger ones fail).
            for (int m = -1; m < kMipLevels; ++m) {
              const int64_t bi = (gbi >> (m + 1)) - (m < 0 ? L.bx0 : L.pyramid[m].bx0);
              const int64_t bj = (gbj >> (m + 1)) - (m < 0 ? L.by0 : L.pyramid[m].by0);
              const int nbx = m < 0 ? L.nbx : L.pyramid[m].nbx, nby = m < 0 ? L.nby : L.pyramid[m].nby;
              if (bi < 0 || bj < 0 || bi >= nbx || bj >= nby) break;
              const double bound = (m < 0 ? L.bound : L.pyramid[m].v)[bj * nbx + bi];
              const double size = L.s * (kBlock << (m + 1));
              const int64_t ci = gbi >> (m + 1), cj = gbj >> (m + 1);
              double t_seg = t_lod;
              if (d.x() > 1e-12) t_seg = std::min(t_seg, ((ci + 1) * size - cam.x()) * inv_dx);
              if (d.x() < -1e-12) t_seg = std::min(t_seg, (ci * size - cam.x()) * inv_dx);
              if (d.y() > 1e-12) t_seg = std::min(t_seg, ((cj + 1) * size - cam.y()) * inv_dy);
              if (d.y() < -1e-12) t_seg = std::min(t_seg, (cj * size - cam.y()) * inv_dy);
              // The ray is above the surface while it stays above the bound plane inside the block: go to
              // the block exit or to where it reaches the plane (1 mm above), whichever is first.
              const double top = bound + 1e-3;
              if (!(p.z() > top) || !std::isfinite(t_seg)) break;
              const double t_plane = d.z() < -1e-12 ? (top - cam.z()) * inv_dz : t_seg;
              if (t_plane < t_seg) {
                skip_to = std::max(skip_to, t_plane);
                break;  // larger blocks have higher planes
              }
              skip_to = t_seg + 1e-5;     // just into the next block (the 1 mm margin covers the overshoot)
              if (t_seg >= t_lod) break;  // the LOD changes there: larger blocks give nothing more
            }
          }
          t_prev = t, g_prev = g;
          t = std::max(t + step, skip_to);
        }
      }
      if (hit) {
        const Eigen::Vector3d p = cam + t * d;
        const double l = lodAt(p.x(), p.y());
        const double e = kBaseSpacing * std::exp2(std::floor(l));
        const double hx = (field(0, p.x() + e, p.y(), l) - field(0, p.x() - e, p.y(), l)) / (2 * e);
        const double hy = (field(0, p.x(), p.y() + e, l) - field(0, p.x(), p.y() - e, l)) / (2 * e);
        Eigen::Vector3d n(-hx, -hy, 1.0);
        if (!n.allFinite()) n = Eigen::Vector3d::UnitZ();
        n.normalize();
        const double albedo = field(1, p.x(), p.y(), l);
        const double shadow_top = field(2, p.x(), p.y(), l);
        const double h = field(0, p.x(), p.y(), l);
        shadowed = n.dot(sun) <= 0.0 || (!std::isnan(shadow_top) && shadow_top > h + 0.05 * e + 1e-3);
        if (!shadowed) {
          reflectance = lunarLambertReflectance(std::isnan(albedo) ? 0.12 : albedo, n, sun, -d);
          value = gain * reflectance;
        }
        depth = t * b.z();
      }
      if (settings.noise_sigma_dn > 0.0) {
        // Read noise + shot noise, from a per-pixel hash: identical whatever the thread schedule.
        const uint64_t hsh =
            detail::hash3(settings.noise_seed ^ (frame_index * 0x9E3779B97F4A7C15ull), row, col);
        const double u1 = std::max(detail::toUnit(hsh), 1e-12), u2 = detail::toUnit(detail::mix64(hsh));
        const double gauss = std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * M_PI * u2);
        const double sigma = settings.noise_sigma_dn * std::sqrt(1.0 + value / 32.0);
        value += sigma * gauss;
      }
      out->image(row, col) = cv::saturate_cast<uchar>(value);
      out->depth(row, col) = static_cast<float>(depth);
      out->shadow(row, col) = shadowed ? 255 : 0;
      if (settings.output_reflectance) out->reflectance(row, col) = static_cast<float>(reflectance);
    }
    total_steps += steps;
  });
  out->stats.mean_ray_steps = static_cast<double>(total_steps) / (static_cast<double>(W) * H);
}

Renderer::Renderer(std::shared_ptr<const LunarTerrain> terrain, const RenderSettings& settings)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!settings.camera.isValid(&why)) throw std::invalid_argument("render: bad camera: " + why);
  if (!terrain) throw std::invalid_argument("render: no terrain");
  impl_->terrain = std::move(terrain);
  impl_->settings = settings;
  impl_->settings.sun_direction.normalize();
  impl_->threads =
      settings.num_threads > 0 ? settings.num_threads : std::max(1u, std::thread::hardware_concurrency());
  const PinholeCamera& cam = impl_->settings.camera;
  if (cam.hasDistortion()) {
    const int W = cam.width(), H = cam.height();
    impl_->distorted_bearings.resize(static_cast<size_t>(W) * H);
    std::atomic<int> not_converged{0};
    parallelFor(H, impl_->threads, [&](int row) {
      for (int col = 0; col < W; ++col) {
        bool ok = true;
        impl_->distorted_bearings[static_cast<size_t>(row) * W + col] =
            cam.pixelToBearing(cam.undistortPixel(Eigen::Vector2d(col, row), &ok));
        if (!ok) ++not_converged;
      }
    });
    if (not_converged > 0)
      throw std::invalid_argument("render: the lens distortion is not invertible at " +
                                  std::to_string(not_converged.load()) + " pixels");
  }
}

Renderer::~Renderer() = default;

const RenderSettings& Renderer::settings() const { return impl_->settings; }
const LunarTerrain& Renderer::terrain() const { return *impl_->terrain; }

RenderOutput Renderer::render(const Pose& T_world_cam, uint64_t frame_index) {
  RenderOutput out;
  auto t0 = Clock::now();
  impl_->setupFrame(T_world_cam, &out.stats);
  out.stats.region_ms = msSince(t0);
  impl_->bakeLevels(&out.stats);
  impl_->buildBlockBounds();
  out.stats.setup_ms = msSince(t0);
  out.stats.assemble_ms = out.stats.setup_ms - out.stats.region_ms - out.stats.bake_ms;
  t0 = Clock::now();
  impl_->sweepShadows();
  out.stats.shadow_ms = msSince(t0);
  t0 = Clock::now();
  impl_->trace(T_world_cam, &out, frame_index);
  out.stats.trace_ms = msSince(t0);
  return out;
}

std::optional<double> castRayOnTerrain(const LunarTerrain& terrain, const Eigen::Vector3d& origin,
                                       const Eigen::Vector3d& direction, double lod_m, double max_range_m) {
  const Eigen::Vector3d d = direction.normalized();
  auto gap = [&](double t) {
    const Eigen::Vector3d p = origin + t * d;
    return p.z() - terrain.height(p.x(), p.y(), lod_m);
  };
  double t = 0.0, g = gap(0.0);
  if (g <= 0.0) return std::nullopt;
  // March with steps bounded by a fraction of the height gap and by the footprint sideways, so no relief
  // feature (all at least ~2 footprints wide) is stepped over; then bisect.
  const double dxy = std::hypot(d.x(), d.y());
  while (t < max_range_m) {
    const double step = std::max(
        std::min(0.5 * g / std::max(-d.z(), 0.05), dxy > 1e-9 ? 2.0 * lod_m / dxy : 1e9), 0.25 * lod_m);
    const double g_next = gap(t + step);
    if (g_next <= 0.0) {
      double a = t, b = t + step;
      for (int i = 0; i < 80 && b - a > 1e-5; ++i) {
        const double m = 0.5 * (a + b);
        (gap(m) > 0.0 ? a : b) = m;
      }
      return 0.5 * (a + b);
    }
    t += step, g = g_next;
  }
  return std::nullopt;
}

}  // namespace planetary_vo::render
