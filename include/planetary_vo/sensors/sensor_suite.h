#pragma once
/// @file sensor_suite.h
/// The sensors of a rendered descent as one set of parameters: camera, IMU and laser altimeter error models,
/// and the named presets the benchmark uses.
///
/// - `flight`: every error model on, with the defaults documented in docs/sensors/ (camera: photon transfer,
///   optics, auto exposure, motion blur, defects, lens distortion and calibration error; IMU: the tactical
///   grade; altimeter: noise, bias, range limits, outliers, beam footprint). The default of lunar_render and
///   of the benchmark.
/// - `ideal`: every model off: noiseless 8-bit images through a perfect pinhole, the exact IMU, the exact
/// range.
///   These are the data of renderer 1.2 bit for bit (the images the peers' figures in peer-results.md were
///   measured on).
///
/// Any parameter can then be overridden from YAML (`camera: {read_noise_e: 20}`, `imu: {grade: mems}`) or
/// with a dotted assignment (`camera.read_noise_e=20`, `imu.gyro.white_noise_density=1e-4`).

#include <cstdint>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "planetary_vo/sensors/altimeter_model.h"
#include "planetary_vo/sensors/camera_sensor.h"
#include "planetary_vo/sensors/imu_model.h"

namespace planetary_vo::sensors {

struct SensorSuiteParams {
  std::string preset;  ///< the preset these parameters started from ("flight", "ideal"); overrides keep it
  CameraSensorParams camera;
  ImuErrorParams imu;
  AltimeterParams altimeter;
};

/// "flight" or "ideal" (see the file comment). Throws std::invalid_argument listing the valid names.
SensorSuiteParams sensorPreset(const std::string& name);
std::vector<std::string> sensorPresetNames();

/// Overrides from a YAML map with the optional keys `preset` (applied first, replacing everything), `camera`,
/// `imu`, `altimeter` (each read by its model's readYaml). Throws std::invalid_argument naming a bad key.
void readYaml(const YAML::Node& node, SensorSuiteParams* params);
/// Every parameter (preset, camera, imu, altimeter), e.g. for sequence.yaml and the render cache's hash.
YAML::Node toYaml(const SensorSuiteParams& params);
/// One dotted assignment "section.key=value" or "section.sub.key=value" (e.g. "camera.psf=airy",
/// "imu.grade=mems", "altimeter.max_range_m=2000"); a list value is written as YAML
/// ("camera.distortion=[-0.04, 0, 0, 0, 0]"). Throws std::invalid_argument.
void applyOverride(const std::string& assignment, SensorSuiteParams* params);
/// Reads a YAML file of overrides (same keys as readYaml). Throws std::invalid_argument naming the file.
void readYamlFile(const std::string& path, SensorSuiteParams* params);

/// Independent seed of one model ("camera", "calibration", "imu", "altimeter") from the run's sensor seed, so
/// that the noise of one sensor does not change when another sensor's parameters do.
uint64_t subSeed(uint64_t sensor_seed, const std::string& model);

/// The YAML text of `node` in block style (stable: used in hashes).
std::string yamlText(const YAML::Node& node);

}  // namespace planetary_vo::sensors
