#pragma once
/// @file grid.h
/// A metric raster over the landing-site world frame (thesis 4.2.2: origin at the landing site, x crossrange,
/// y downrange, z up) and a named set of float layers on it, with their files.
///
/// Layout (the one of nav_msgs/OccupancyGrid): cell (col, row) is centred at world
/// (x0_m + col * cell_size_m, y0_m + row * cell_size_m); columns run along +x, rows along +y, so row 0 is the
/// smallest y (shown as an image, +y points down). A layer is a cv::Mat of `rows` x `cols` CV_32F, element
/// (row, col); NaN = unknown.
///
/// Files (writeGridSet / readGridSet): `<dir>/<name>.yaml` (geometry, layer files, description, parameters)
/// and one 32-bit float TIFF per layer, `<dir>/<name>_<layer>.tiff`. Reading gives back exactly what was
/// written (bits of every float, NaN included; doubles of the geometry to 17 digits).

#include <limits>
#include <map>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

namespace planetary_vo::terrain {

struct GridGeometry {
  double x0_m = 0.0;  ///< world x of the centre of cell (col 0, row 0)
  double y0_m = 0.0;  ///< world y of the centre of cell (col 0, row 0)
  double cell_size_m = 1.0;
  int cols = 0;  ///< cells along +x
  int rows = 0;  ///< cells along +y

  /// A square of (2 * round(half_extent_m / cell_size_m) + 1) cells a side whose centre cell is centred on
  /// world (x, y) = (0, 0). Throws std::invalid_argument unless 0 < cell_size_m <= half_extent_m.
  static GridGeometry centeredOnOrigin(double half_extent_m, double cell_size_m);

  double x_m(int col) const { return x0_m + col * cell_size_m; }  ///< world x of a column's cell centres
  double y_m(int row) const { return y0_m + row * cell_size_m; }  ///< world y of a row's cell centres
  /// The cell whose square contains world (x, y) (cell edges at centre +- cell_size_m / 2); false outside.
  bool cellAt(double x_m, double y_m, int* col, int* row) const;
  bool contains(int col, int row) const { return col >= 0 && row >= 0 && col < cols && row < rows; }
  /// A new CV_32F layer of this size filled with `value` (NaN = unknown by default).
  cv::Mat newLayer(float value = std::numeric_limits<float>::quiet_NaN()) const;

  bool operator==(const GridGeometry& o) const {
    return x0_m == o.x0_m && y0_m == o.y0_m && cell_size_m == o.cell_size_m && cols == o.cols &&
           rows == o.rows;
  }
  bool operator!=(const GridGeometry& o) const { return !(*this == o); }
};

/// Layers on one geometry. Layer names carry their unit (`elevation_m`, `slope_deg`, `roughness_m`) and must
/// be usable in a file name ([A-Za-z0-9_]).
struct GridSet {
  GridGeometry geometry;
  std::map<std::string, cv::Mat> layers;     ///< name -> rows x cols CV_32FC1
  std::string description;                   ///< free text, written as a comment and a `description` key
  std::map<std::string, double> parameters;  ///< how the layers were made (e.g. `footprint_diameter_m`)
};

/// Thrown by readGridSet / writeGridSet with a message naming the file.
class GridFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes `<dir>/<name>.yaml` and `<dir>/<name>_<layer>.tiff` (dir must exist). Throws GridFileError on a
/// layer of the wrong size or type, a bad name, or a file that cannot be written.
void writeGridSet(const std::string& dir, const std::string& name, const GridSet& grids);
/// Reads what writeGridSet wrote. Throws GridFileError on a missing or malformed file.
GridSet readGridSet(const std::string& dir, const std::string& name);

}  // namespace planetary_vo::terrain
