/// @file read_tum_rgbd.cpp
/// Reader of a TUM RGB-D folder: rgb.txt + rgb/*.png (color, read as gray), groundtruth.txt of the color
/// camera's optical frame at the motion-capture stamps, interpolated to the image stamps. Intrinsics from
/// camera.yaml if present, else the ROS default of the benchmark (fx = fy = 525, cx = 319.5, cy = 239.5,
/// 640x480).

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

using namespace dataset_internal;

Dataset DatasetReaders::readTumRgbd(const std::string& directory) {
  const std::string d = directory + "/";
  Dataset dataset;
  dataset.format_ = DatasetFormat::kTumRgbd;
  dataset.directory_ = directory;
  dataset.name_ = baseName(directory);
  dataset.camera_ = isFile(d + "camera.yaml") ? readCameraInfoYaml(d + "camera.yaml")
                                              : PinholeCamera(640, 480, 525.0, 525.0, 319.5, 239.5);

  const std::string list = d + "rgb.txt";
  for (const TextRow& row : readTextTable(list, false)) {
    requireColumns(list, row, 2, true);
    const double t = parseDouble(list, row, 0);
    if (!dataset.timestamps_s_.empty()) requireIncreasing(list, row, dataset.timestamps_s_.back(), t);
    const std::string image_path = d + row.tokens[1];
    if (!isFile(image_path))
      throw DatasetError(list + ":" + std::to_string(row.line_number) + ": image " + image_path +
                         " does not exist");
    dataset.timestamps_s_.push_back(t);
    dataset.image_paths_.push_back(image_path);
  }
  if (isFile(d + "groundtruth.txt"))
    setInterpolatedGroundTruth(&dataset, readTumTrajectory(d + "groundtruth.txt"));
  checkConsistent(dataset);
  return dataset;
}

}  // namespace planetary_vo
