/// gtest node of vo_params.test: config YAML files loaded into the parameter server with rosparam and read
/// back by ros_params (loadVoConfigFromParams) give the same VoConfig as the core YAML loader; a changed
/// parameter changes the struct; a misspelt key, section or nodelet parameter is an error that names it.

#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <ros/ros.h>

#include "planetary_vo/ros_io/ros_params.h"
#include "planetary_vo/vo/config_yaml.h"

namespace planetary_vo::ros_io {
namespace {

VoConfig fromParams(const std::string& ns) { return loadVoConfigFromParams(ros::NodeHandle("~" + ns)); }
VoConfig fromYaml(const std::string& name) {
  return planetary_vo::loadVoConfig(std::string(PLANETARY_VO_SOURCE_DIR) + "/config/" + name + ".yaml");
}

TEST(VoParams, RosparamEqualsYamlLoader) {
  for (const std::string name : {"default", "thesis_E", "thesis_H"}) {
    SCOPED_TRACE(name);
    const VoConfig a = fromParams(name), b = fromYaml(name);
    EXPECT_TRUE(a == b) << "rosparam:\n" << a.dump() << "\nyaml:\n" << b.dump();
  }
  EXPECT_TRUE(fromParams("default") == VoConfig());
  EXPECT_FALSE(fromParams("thesis_E") == VoConfig());  // the comparison can fail
}

TEST(VoParams, ChangedParameterIsRead) {
  const VoConfig c = fromParams("changed");
  EXPECT_EQ(c.detector.num_features, 123);
  EXPECT_EQ(c.motion.model, MotionModel::kHomography);
  EXPECT_EQ(c.tracker.window_size_px, VoConfig().tracker.window_size_px);  // absent keys keep their default
}

TEST(VoParams, MisspeltKeyIsNamed) {
  try {
    fromParams("misspelt");
    FAIL() << "no error for ~detector/num_featurs";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("num_featurs"), std::string::npos) << e.what();
  }
}

TEST(VoParams, MisspeltSectionsAndParametersAreNamed) {
  // Issue 12: a misspelt section under ~ (~detecter/num_features) was silently ignored: the nodelet ran on
  // the default it was meant to change. Every name under the private namespace must be a parameter or a
  // section the nodelet reads.
  std::vector<std::string> known = nodeletParamNames();
  known.insert(known.end(), std::begin(kVoConfigSections), std::end(kVoConfigSections));
  EXPECT_TRUE(unknownPrivateNames(ros::NodeHandle("~default"), known).empty())
      << "config/default.yaml has only sections";
  EXPECT_TRUE(unknownPrivateNames(ros::NodeHandle("~nodelet_params"), known).empty());
  const std::vector<std::string> unknown = unknownPrivateNames(ros::NodeHandle("~typos"), known);
  ASSERT_EQ(unknown.size(), 2u);
  std::string all;
  for (const std::string& u : unknown) all += u + "\n";
  EXPECT_NE(all.find("typos/detecter: not a section"), std::string::npos) << all;
  EXPECT_NE(all.find("typos/max_path_lenght: not a parameter"), std::string::npos) << all;
  // The hazard nodelet's names: its config/hazard.yaml sections and parameters are all known.
  std::vector<std::string> hazard_known = hazardNodeletParamNames();
  hazard_known.insert(hazard_known.end(), hazardConfigSections().begin(), hazardConfigSections().end());
  EXPECT_TRUE(unknownPrivateNames(ros::NodeHandle("~hazard"), hazard_known).empty());
  EXPECT_EQ(unknownPrivateNames(ros::NodeHandle("~hazard_typo"), hazard_known).size(), 1u);
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_vo_params");
  return RUN_ALL_TESTS();
}
