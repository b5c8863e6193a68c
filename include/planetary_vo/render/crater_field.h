#pragma once
/// @file crater_field.h
/// Procedural population of simple craters and boulders, infinite and deterministic.
///
/// Craters are split into octave size classes [D_k, 2 D_k). Each class has its own spatial hash grid whose
/// cell size is proportional to D_k (so that a crater only reaches its own cell and the 8 neighbours): the
/// content of a cell is a pure function of (seed, class, cell), generated on demand, so a query visits at
/// most 9 cells per class and needs no storage. The expected count per cell follows the cumulative
/// size-frequency law N(>D) = density * D^-2 (per m^2, D in m), and diameters inside a class are drawn from
/// the matching D^-3 density. Each crater has a freshness in [0, 1]: fresh craters are deep (d/D = 0.2), with
/// raised rims, a bright ejecta blanket and boulders; old ones are shallow, rounded and of background albedo.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace planetary_vo::render {

struct CraterFieldParams {
  double density = 0.08;              ///< N(>D) = density * D^-2 craters per m^2
  double min_diameter_m = 0.25;       ///< smallest crater class
  double max_diameter_m = 640.0;      ///< largest crater class (bigger ones come from the DEM)
  double fresh_exponent = 3.0;        ///< freshness = u^exponent: larger -> fewer fresh craters
  double boulder_min_crater_m = 6.0;  ///< fresh craters at least this large throw boulders
};

struct Crater {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double diameter_m = 0.0;
  double freshness = 0.0;     ///< 1 = fresh, 0 = fully degraded
  double depth_m = 0.0;       ///< rim crest to floor
  double rim_height_m = 0.0;  ///< rim crest above the surroundings
  uint64_t id = 0;
};

class CraterField {
 public:
  static constexpr int kMaxPerCell = 4;

  CraterField(uint64_t seed, const CraterFieldParams& params);

  int numClasses() const { return num_classes_; }
  double classDiameter(int k) const;  ///< smallest diameter of class k
  double cellSize(int k) const;
  /// Craters of class k whose centre is in cell (i, j); returns their number (<= kMaxPerCell).
  int cellCraters(int k, int64_t i, int64_t j, Crater* out) const;

  /// Height and albedo change at (x, y) from all craters and boulders resolvable at level of detail `lod_m`
  /// (the ground size of one pixel): features smaller than about two footprints fade out instead of aliasing.
  struct Contribution {
    double height_m = 0.0;
    double albedo = 0.0;
  };
  Contribution evaluate(double x, double y, double lod_m) const;

  /// evaluate() at every node (xs[i], ys[j]) of a grid (xs, ys increasing), added to height[j * nx + i] and
  /// albedo[...]. Bit-identical to evaluate() node by node, but splats each crater and boulder onto the nodes
  /// it reaches instead of hashing 9 cells per class per node: ~0.6 crater evaluations per node and class
  /// instead of 9 cell generations (this is the renderer's baking hot spot).
  void evaluateGrid(const std::vector<double>& xs, const std::vector<double>& ys, double lod_m,
                    double* height, double* albedo) const;

  /// Relief of one crater alone at distance r from its centre (used by evaluate and by the tests).
  static double craterProfile(const Crater& c, double r);

  const CraterFieldParams& params() const { return params_; }

 private:
  void addBoulders(const Crater& c, double x, double y, double rho, double lod_m, Contribution* out) const;
  void splatBoulders(const Crater& c, const std::vector<double>& xs, const std::vector<double>& ys, int i0,
                     int i1, int j0, int j1, double lod_m, double* height, double* albedo) const;

  uint64_t seed_;
  CraterFieldParams params_;
  int num_classes_ = 0;
  double lambda_ = 0.0, exp_minus_lambda_ = 1.0;
};

}  // namespace planetary_vo::render
