#include "planetary_vo/render/crater_field.h"

#include <algorithm>
#include <cmath>

#include "noise.h"

namespace planetary_vo::render {

using detail::hash3;
using detail::HashRng;
using detail::smoothstep;

namespace {
constexpr double kEjectaRadius = 2.5;  // ejecta blanket and rim uplift reach 2.5 crater radii
constexpr double kCellPerDiameter =
    2.5;  // cell = 2.5 D_k >= ejecta radius of the largest crater of the class

// Polynomial smooth minimum: rounds the rim crest of degraded craters over a width k (in metres of height).
inline double smin(double a, double b, double k) {
  if (k <= 0) return std::min(a, b);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}
}  // namespace

CraterField::CraterField(uint64_t seed, const CraterFieldParams& params) : seed_(seed), params_(params) {
  num_classes_ =
      std::max(0, static_cast<int>(std::floor(std::log2(params.max_diameter_m / params.min_diameter_m))));
  // The expected count per cell is the same for every class (cell ~ D_k): density * 0.75 * 2.5^2.
  lambda_ = params.density * 0.75 * kCellPerDiameter * kCellPerDiameter;
  exp_minus_lambda_ = std::exp(-lambda_);
}

double CraterField::classDiameter(int k) const { return params_.min_diameter_m * std::ldexp(1.0, k); }
double CraterField::cellSize(int k) const { return kCellPerDiameter * classDiameter(k); }

int CraterField::cellCraters(int k, int64_t i, int64_t j, Crater* out) const {
  HashRng rng(hash3(seed_ ^ 0xC4A7E5ull, i, j, k));
  const double dk = classDiameter(k), cell = cellSize(k);
  // Expected number in the cell from the cumulative law: density * (D_k^-2 - (2 D_k)^-2) * cell^2.
  const double lambda = lambda_;
  // Poisson draw by inversion (lambda is well below 1, so kMaxPerCell truncation is negligible).
  const double u = rng.uniform();
  int n = 0;
  double p = exp_minus_lambda_, cdf = p;
  while (u > cdf && n < kMaxPerCell) {
    ++n;
    p *= lambda / n;
    cdf += p;
  }
  for (int c = 0; c < n; ++c) {
    Crater& cr = out[c];
    cr.center = {(i + rng.uniform()) * cell, (j + rng.uniform()) * cell};
    // D^-3 density on [D_k, 2 D_k) by inversion: the cumulative D^-2 law holds inside the class too.
    cr.diameter_m = dk / std::sqrt(1.0 - 0.75 * rng.uniform());
    // Large craters are older on average (a fresh crater of that size is rare): fewer deep, sharp big bowls.
    const double uf = rng.uniform();
    const double expo = params_.fresh_exponent * std::max(1.0, std::sqrt(dk / 20.0));
    cr.freshness = std::pow(uf, expo);
    const double f = cr.freshness;
    cr.depth_m = cr.diameter_m * (0.2 * f + 0.04 * (1.0 - f));         // d/D: 0.2 fresh, 0.04 degraded
    cr.rim_height_m = cr.diameter_m * (0.04 * f + 0.004 * (1.0 - f));  // rim uplift erodes away with age
    cr.id = hash3(seed_, i, j, k * 8 + c);
  }
  return n;
}

double CraterField::craterProfile(const Crater& c, double r) {
  const double radius = 0.5 * c.diameter_m;
  const double rho = r / radius;
  if (rho >= kEjectaRadius) return 0.0;
  const double inner = c.rim_height_m - c.depth_m * (1.0 - rho * rho);  // parabolic bowl
  constexpr double kFar = 1.0 / (kEjectaRadius * kEjectaRadius * kEjectaRadius);
  const double rr = std::max(rho, 1e-3);
  const double outer =
      c.rim_height_m * (1.0 / (rr * rr * rr) - kFar) / (1.0 - kFar);  // ejecta thinning ~ r^-3
  // Fresh rims are sharp crests; degraded rims are rounded over ~30 % of the depth.
  const double k = c.depth_m * (0.02 + 0.3 * (1.0 - c.freshness));
  return smin(inner, outer, k);
}

void CraterField::addBoulders(const Crater& c, double x, double y, double rho, double lod_m,
                              Contribution* out) const {
  // Largest block ~0.29 D^0.66 (Bart & Melosh 2010), capped for small craters.
  const double b_max = std::min(0.29 * std::pow(c.diameter_m, 0.66), 0.05 * c.diameter_m);
  const double fade = smoothstep(lod_m, 2.0 * lod_m, b_max);
  if (fade <= 0.0 || rho < 0.5 || rho > 2.3) return;
  const double cell = 1.5 * b_max;
  const double lx = x - c.center.x(), ly = y - c.center.y();
  const int64_t ci = static_cast<int64_t>(std::floor(lx / cell)),
                cj = static_cast<int64_t>(std::floor(ly / cell));
  const double radius = 0.5 * c.diameter_m;
  for (int64_t i = ci - 1; i <= ci + 1; ++i) {
    for (int64_t j = cj - 1; j <= cj + 1; ++j) {
      HashRng rng(hash3(c.id, i, j, 77));
      const double bx = (i + rng.uniform()) * cell, by = (j + rng.uniform()) * cell;
      const double brho = std::hypot(bx, by) / radius;
      // Blocks are concentrated on the rim and the proximal ejecta, fewer on the walls, none far out.
      const double envelope = std::exp(-std::pow((brho - 1.1) / 0.4, 2)) + (brho < 1.0 ? 0.25 * brho : 0.0);
      if (rng.uniform() > 0.6 * fade * envelope) continue;
      const double diameter = b_max * (0.25 + 0.75 * std::pow(rng.uniform(), 3.0));
      const double rb = 0.5 * diameter;
      const double d2 = (lx - bx) * (lx - bx) + (ly - by) * (ly - by);
      if (d2 >= rb * rb) continue;
      const double w = smoothstep(0.5 * lod_m, lod_m, diameter);
      out->height_m += w * 0.7 * rb * std::sqrt(1.0 - d2 / (rb * rb));  // half-buried ellipsoidal block
      out->albedo += w * 0.03;
    }
  }
}

CraterField::Contribution CraterField::evaluate(double x, double y, double lod_m) const {
  Contribution sum;
  Crater craters[kMaxPerCell];
  for (int k = num_classes_ - 1; k >= 0; --k) {
    const double dk = classDiameter(k);
    if (2.0 * dk <= 2.0 * lod_m) break;  // whole class below two footprints: invisible, skip (no aliasing)
    const double cell = cellSize(k);
    const int64_t ci = static_cast<int64_t>(std::floor(x / cell)),
                  cj = static_cast<int64_t>(std::floor(y / cell));
    for (int64_t i = ci - 1; i <= ci + 1; ++i) {
      for (int64_t j = cj - 1; j <= cj + 1; ++j) {
        const int n = cellCraters(k, i, j, craters);
        for (int c = 0; c < n; ++c) {
          const Crater& cr = craters[c];
          const double r = std::hypot(x - cr.center.x(), y - cr.center.y());
          const double radius = 0.5 * cr.diameter_m;
          if (r >= kEjectaRadius * radius) continue;
          const double w = smoothstep(2.0 * lod_m, 4.0 * lod_m, cr.diameter_m);
          if (w <= 0.0) continue;
          sum.height_m += w * craterProfile(cr, r);
          const double rho = r / radius;
          if (cr.freshness > 0.45) {
            // Fresh ejecta and walls expose immature, brighter regolith; it darkens with exposure age.
            const double bright = (cr.freshness - 0.45) / 0.55;
            const double env = rho < 1.0 ? 0.5 + 0.5 * rho * rho : (1.0 - (rho - 1.0) / 1.5) / (rho * rho);
            sum.albedo += w * 0.07 * bright * env;
            if (cr.diameter_m >= params_.boulder_min_crater_m) addBoulders(cr, x, y, rho, lod_m, &sum);
          }
        }
      }
    }
  }
  return sum;
}

}  // namespace planetary_vo::render

namespace planetary_vo::render {

namespace {
// Index range [first, last) of the increasing values v within [lo, hi].
inline void rangeWithin(const std::vector<double>& v, double lo, double hi, int* first, int* last) {
  *first = static_cast<int>(std::lower_bound(v.begin(), v.end(), lo) - v.begin());
  *last = static_cast<int>(std::upper_bound(v.begin(), v.end(), hi) - v.begin());
}
// Index range [first, last) of the nondecreasing cell indices c within [lo, hi].
inline void cellRange(const std::vector<int64_t>& c, int64_t lo, int64_t hi, int* first, int* last) {
  *first = static_cast<int>(std::lower_bound(c.begin(), c.end(), lo) - c.begin());
  *last = static_cast<int>(std::upper_bound(c.begin(), c.end(), hi) - c.begin());
}
}  // namespace

void CraterField::splatBoulders(const Crater& c, const std::vector<double>& xs, const std::vector<double>& ys,
                                int i0, int i1, int j0, int j1, double lod_m, double* height,
                                double* albedo) const {
  // Same quantities and draws as addBoulders, computed once per boulder instead of once per node.
  const double b_max = std::min(0.29 * std::pow(c.diameter_m, 0.66), 0.05 * c.diameter_m);
  const double fade = smoothstep(lod_m, 2.0 * lod_m, b_max);
  if (fade <= 0.0) return;
  const double cell = 1.5 * b_max;
  const double radius = 0.5 * c.diameter_m;
  const int nx = static_cast<int>(xs.size());
  // Boulder cells seen by nodes with rho <= 2.3 (their 3x3 neighbourhoods).
  const int64_t reach = static_cast<int64_t>(std::floor(2.3 * radius / cell)) + 2;
  const int64_t ci = static_cast<int64_t>(std::floor((xs[i0] - c.center.x()) / cell)),
                ce = static_cast<int64_t>(std::floor((xs[i1 - 1] - c.center.x()) / cell));
  const int64_t cj = static_cast<int64_t>(std::floor((ys[j0] - c.center.y()) / cell)),
                cf = static_cast<int64_t>(std::floor((ys[j1 - 1] - c.center.y()) / cell));
  for (int64_t i = std::max(ci - 1, -reach); i <= std::min(ce + 1, reach); ++i) {
    for (int64_t j = std::max(cj - 1, -reach); j <= std::min(cf + 1, reach); ++j) {
      HashRng rng(hash3(c.id, i, j, 77));
      const double bx = (i + rng.uniform()) * cell, by = (j + rng.uniform()) * cell;
      const double brho = std::hypot(bx, by) / radius;
      const double envelope = std::exp(-std::pow((brho - 1.1) / 0.4, 2)) + (brho < 1.0 ? 0.25 * brho : 0.0);
      if (rng.uniform() > 0.6 * fade * envelope) continue;
      const double diameter = b_max * (0.25 + 0.75 * std::pow(rng.uniform(), 3.0));
      const double rb = 0.5 * diameter;
      const double w = smoothstep(0.5 * lod_m, lod_m, diameter);
      int a0, a1, b0, b1;
      rangeWithin(xs, c.center.x() + bx - 1.01 * rb, c.center.x() + bx + 1.01 * rb, &a0, &a1);
      rangeWithin(ys, c.center.y() + by - 1.01 * rb, c.center.y() + by + 1.01 * rb, &b0, &b1);
      a0 = std::max(a0, i0), a1 = std::min(a1, i1), b0 = std::max(b0, j0), b1 = std::min(b1, j1);
      for (int b = b0; b < b1; ++b) {
        const double ly = ys[b] - c.center.y();
        const int64_t nj = static_cast<int64_t>(std::floor(ly / cell));
        if (nj < j - 1 || nj > j + 1) continue;  // the node's own 3x3 boulder cells exclude this one
        for (int a = a0; a < a1; ++a) {
          const double lx = xs[a] - c.center.x();
          const int64_t ni = static_cast<int64_t>(std::floor(lx / cell));
          if (ni < i - 1 || ni > i + 1) continue;
          const double r = std::hypot(xs[a] - c.center.x(), ys[b] - c.center.y());
          if (r >= kEjectaRadius * radius) continue;
          const double rho = r / radius;
          if (rho < 0.5 || rho > 2.3) continue;
          const double d2 = (lx - bx) * (lx - bx) + (ly - by) * (ly - by);
          if (d2 >= rb * rb) continue;
          height[b * nx + a] += w * 0.7 * rb * std::sqrt(1.0 - d2 / (rb * rb));
          albedo[b * nx + a] += w * 0.03;
        }
      }
    }
  }
}

void CraterField::evaluateGrid(const std::vector<double>& xs, const std::vector<double>& ys, double lod_m,
                               double* height, double* albedo) const {
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  if (nx == 0 || ny == 0) return;
  Crater craters[kMaxPerCell];
  std::vector<int64_t> cx(nx), cy(ny);
  // Classes, cells and craters in the order evaluate() visits them, so every node sums its contributions in
  // the same order (identical floating-point result).
  for (int k = num_classes_ - 1; k >= 0; --k) {
    const double dk = classDiameter(k);
    if (2.0 * dk <= 2.0 * lod_m) break;
    const double cell = cellSize(k);
    for (int i = 0; i < nx; ++i) cx[i] = static_cast<int64_t>(std::floor(xs[i] / cell));
    for (int j = 0; j < ny; ++j) cy[j] = static_cast<int64_t>(std::floor(ys[j] / cell));
    for (int64_t i = cx.front() - 1; i <= cx.back() + 1; ++i) {
      int ci0, ci1;
      cellRange(cx, i - 1, i + 1, &ci0, &ci1);  // nodes whose 3x3 cells include cell i
      if (ci0 >= ci1) continue;
      for (int64_t j = cy.front() - 1; j <= cy.back() + 1; ++j) {
        int cj0, cj1;
        cellRange(cy, j - 1, j + 1, &cj0, &cj1);
        if (cj0 >= cj1) continue;
        const int n = cellCraters(k, i, j, craters);
        for (int c = 0; c < n; ++c) {
          const Crater& cr = craters[c];
          const double radius = 0.5 * cr.diameter_m;
          const double w = smoothstep(2.0 * lod_m, 4.0 * lod_m, cr.diameter_m);
          if (w <= 0.0) continue;
          const double reach = kEjectaRadius * radius;
          int a0, a1, b0, b1;
          rangeWithin(xs, cr.center.x() - 1.01 * reach, cr.center.x() + 1.01 * reach, &a0, &a1);
          rangeWithin(ys, cr.center.y() - 1.01 * reach, cr.center.y() + 1.01 * reach, &b0, &b1);
          a0 = std::max(a0, ci0), a1 = std::min(a1, ci1), b0 = std::max(b0, cj0), b1 = std::min(b1, cj1);
          if (a0 >= a1 || b0 >= b1) continue;
          const bool fresh = cr.freshness > 0.45;
          const double bright = (cr.freshness - 0.45) / 0.55;
          for (int b = b0; b < b1; ++b)
            for (int a = a0; a < a1; ++a) {
              const double r = std::hypot(xs[a] - cr.center.x(), ys[b] - cr.center.y());
              if (r >= reach) continue;
              height[b * nx + a] += w * craterProfile(cr, r);
              if (fresh) {
                const double rho = r / radius;
                const double env =
                    rho < 1.0 ? 0.5 + 0.5 * rho * rho : (1.0 - (rho - 1.0) / 1.5) / (rho * rho);
                albedo[b * nx + a] += w * 0.07 * bright * env;
              }
            }
          if (fresh && cr.diameter_m >= params_.boulder_min_crater_m)
            splatBoulders(cr, xs, ys, a0, a1, b0, b1, lod_m, height, albedo);
        }
      }
    }
  }
}

}  // namespace planetary_vo::render
