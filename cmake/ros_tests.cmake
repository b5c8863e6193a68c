# Tests of the ROS layer, included by the top CMakeLists.txt inside if(CATKIN_ENABLE_TESTING).
#
#   ros_test_conversions   gtest, no master: core types <-> messages
#   ros_test_player_core   gtest, no master: the player stream (KITTI clip + synthetic planetary_vo dataset with
#                          IMU/altimeter), looping, start index, epoch, bag writer + rosbag C++ read-back
#   rostests (test/ros/*.test with the gtest node test_player_node):
#     player_live          player node on the KITTI clip: images, camera_info, ground truth, path, tf, /clock, pause
#     player_live_synthetic  the same on the synthetic dataset: IMU and altimeter too
#     player_bag           `rosbag play` of the bag written at build time by `player --dataset --bag`, same checks
find_package(rostest REQUIRED)

set(PLANETARY_VO_ROS_TEST_OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/test_output)

catkin_add_gtest(ros_test_conversions test/ros/test_conversions.cpp)
if(TARGET ros_test_conversions)
  target_link_libraries(ros_test_conversions planetary_vo_ros GTest::gtest_main)
endif()

catkin_add_gtest(ros_test_player_core test/ros/test_player_core.cpp WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
if(TARGET ros_test_player_core)
  target_link_libraries(ros_test_player_core planetary_vo_ros GTest::gtest_main)
  target_include_directories(ros_test_player_core PRIVATE ${PROJECT_SOURCE_DIR}/test ${PROJECT_SOURCE_DIR}/test/ros)
  target_compile_definitions(ros_test_player_core PRIVATE
    PLANETARY_VO_DATA_DIR="${PLANETARY_VO_DATA_DIR}"
    PLANETARY_VO_TEST_OUTPUT_DIR="${PLANETARY_VO_ROS_TEST_OUTPUT}")
endif()
