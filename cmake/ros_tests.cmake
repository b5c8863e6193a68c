# Tests of the ROS layer, included by the top CMakeLists.txt inside if(CATKIN_ENABLE_TESTING).
#
#   ros_test_conversions   gtest, no master: core types <-> messages
#   ros_test_containment   gtest, no master: the exception containment of every callback (ros_io/containment.h)
#   ros_test_player_core   gtest, no master: the player stream (KITTI clip + synthetic planetary_vo dataset with
#                          IMU/altimeter), looping, start index, epoch, bag writer + rosbag C++ read-back
#   rostests (test/ros/*.test with the gtest node test_player_node):
#     player_live          player node on the KITTI clip: images, camera_info, ground truth, path, tf, /clock, pause
#     player_live (synthetic dataset ARGS)  the same with IMU and altimeter
#     player_bag (KITTI, synthetic)  `rosbag play` of the bags written at build time by `player --bag`, same checks
find_package(rostest REQUIRED)

set(PLANETARY_VO_ROS_TEST_OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/test_output)

catkin_add_gtest(ros_test_conversions test/ros/test_conversions.cpp)
if(TARGET ros_test_conversions)
  target_link_libraries(ros_test_conversions planetary_vo_ros GTest::gtest_main)
  planetary_vo_ros_target(ros_test_conversions)
endif()

catkin_add_gtest(ros_test_containment test/ros/test_containment.cpp)
if(TARGET ros_test_containment)
  target_link_libraries(ros_test_containment planetary_vo_ros GTest::gtest_main)
  planetary_vo_ros_target(ros_test_containment)
endif()

catkin_add_gtest(ros_test_player_core test/ros/test_player_core.cpp WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
if(TARGET ros_test_player_core)
  target_link_libraries(ros_test_player_core planetary_vo_ros GTest::gtest_main)
  planetary_vo_ros_target(ros_test_player_core)
  target_include_directories(ros_test_player_core PRIVATE ${PROJECT_SOURCE_DIR}/test)
  target_compile_definitions(ros_test_player_core PRIVATE
    PLANETARY_VO_DATA_DIR="${PLANETARY_VO_DATA_DIR}"
    PLANETARY_VO_TEST_OUTPUT_DIR="${PLANETARY_VO_ROS_TEST_OUTPUT}")
endif()

# Test data made at build time (target player_test_data, built with `tests`): the synthetic planetary_vo-format
# dataset, and bags written by `player --dataset DIR --bag FILE` from it and from the KITTI clip.
set(PLAYER_SYNTHETIC_DATASET ${PLANETARY_VO_ROS_TEST_OUTPUT}/player_synthetic)
set(PLAYER_KITTI_BAG ${PLANETARY_VO_ROS_TEST_OUTPUT}/player_kitti_clip_turn.bag)
set(PLAYER_SYNTHETIC_BAG ${PLANETARY_VO_ROS_TEST_OUTPUT}/player_synthetic.bag)
add_executable(make_player_test_dataset EXCLUDE_FROM_ALL test/ros/make_player_test_dataset.cpp)
target_link_libraries(make_player_test_dataset planetary_vo_dataset)
add_custom_command(
  OUTPUT ${PLAYER_SYNTHETIC_DATASET}/times.txt
  COMMAND ${CMAKE_COMMAND} -E remove_directory ${PLAYER_SYNTHETIC_DATASET}
  COMMAND make_player_test_dataset ${PLAYER_SYNTHETIC_DATASET}
  DEPENDS make_player_test_dataset
  COMMENT "Writing the synthetic player test dataset")
add_custom_command(
  OUTPUT ${PLAYER_KITTI_BAG}
  COMMAND player --dataset ${PLANETARY_VO_DATA_DIR}/kitti_clip_turn --bag ${PLAYER_KITTI_BAG}
  DEPENDS player ${PLANETARY_VO_DATA_DIR}/kitti_clip_turn/poses.txt
  COMMENT "Writing the KITTI clip bag with player --bag")
add_custom_command(
  OUTPUT ${PLAYER_SYNTHETIC_BAG}
  COMMAND player --dataset ${PLAYER_SYNTHETIC_DATASET} --bag ${PLAYER_SYNTHETIC_BAG}
  DEPENDS player ${PLAYER_SYNTHETIC_DATASET}/times.txt
  COMMENT "Writing the synthetic dataset bag with player --bag")
add_custom_target(player_test_data DEPENDS ${PLAYER_SYNTHETIC_DATASET}/times.txt ${PLAYER_KITTI_BAG}
                                           ${PLAYER_SYNTHETIC_BAG})
add_dependencies(tests player_test_data player)

# The gtest node of the rostests. Built by hand rather than with add_rostest_gtest, which cannot pass ARGS.
if(TARGET GTest::gtest)
  add_executable(test_player_node EXCLUDE_FROM_ALL test/ros/test_player_node.cpp)
  target_link_libraries(test_player_node planetary_vo_ros GTest::gtest)
  planetary_vo_ros_target(test_player_node)
  add_dependencies(tests test_player_node)
  add_rostest(test/ros/player_live.test ARGS data_dir:=${PLANETARY_VO_DATA_DIR}
              DEPENDENCIES test_player_node player)
  add_rostest(test/ros/player_live.test ARGS data_dir:=${PLANETARY_VO_DATA_DIR}
              dataset:=${PLAYER_SYNTHETIC_DATASET} rate:=1 expect_fx:=0 name:=synthetic
              DEPENDENCIES test_player_node player player_test_data)
  add_rostest(test/ros/player_bag.test ARGS bag:=${PLAYER_KITTI_BAG}
              dataset:=${PLANETARY_VO_DATA_DIR}/kitti_clip_turn expect_fx:=718.856 name:=kitti
              DEPENDENCIES test_player_node player_test_data)
  add_rostest(test/ros/player_bag.test ARGS bag:=${PLAYER_SYNTHETIC_BAG} dataset:=${PLAYER_SYNTHETIC_DATASET}
              name:=synthetic
              DEPENDENCIES test_player_node player_test_data)
else()
  message(WARNING "GTest not found: the player rostests are not built (install libgtest-dev)")
endif()

# ---------------------------------------------------------------------------------------------------------------
# VO nodelet tests
#   ros_test_vo_conversions  gtest, no master: image conversion, input checks, status/odometry/cloud conversions
#   ros_test_map_event_conversions  gtest, no master: MapEvents <-> VoMapEvents (vo/map_events) round trip, checks
#   rostests with the gtest nodes
#     test_vo_node       vo_end_to_end (player node -> nodelet) and vo_bag (rosbag play of a `player --bag` bag):
#                        Sim(3) ATE bound, map, tf world -> camera, status stream; vo_reconfigure: the same with the
#                        dynamic_reconfigure knobs changed mid-run (in place: no re-initialisation, no scale jump)
#     test_vo_bad_input  vo_bad_input_<case>: crafted images/camera_info published directly to the nodelet;
#                        case samples: bad IMU / altimeter samples into the fused configuration
#     test_vo_manager    vo_reload: unload and reload of the nodelet in a running manager
#     test_vo_params     vo_params: config/default.yaml through rosparam == loadVoConfig(default.yaml)
#     test_vo_fused      vo_fused: player (with the nav/initial_state handover) -> nodelet with
#                        config/lunar_fused.yaml; nav/odometry against ground truth without alignment, at the
#                        IMU rate; vo/status mode, metric, inertial, counters; vo_altimeter: the same with
#                        config/lunar_altimeter.yaml (no IMU: image rate, the motion filter's velocity);
#                        vo_dead_reckoning: every image refused, nav/odometry from the IMU alone
#     test_hazard_node   hazard_end_to_end: the AGNC graph (player -> VO -> hazard nodelet in one manager):
#                        hazard/map against the true ground under the camera, occupancy, sites, status, a
#                        malformed vo/map_events rejected
#     test_vo_fuzz       vo_fuzz: ~250 seeded random malformed Image / CameraInfo / Imu / Range messages between
#                        good frames into the fused configuration: alive, finite poses, a reason for every
#                        rejection ($PLANETARY_VO_FUZZ_SEED; docs/ros_interface.md "Fuzz tests")
#   ros_test_hazard_conversions  gtest, no master: hazard products <-> messages
# ---------------------------------------------------------------------------------------------------------------
foreach(name vo_conversions hazard_conversions map_event_conversions)
  catkin_add_gtest(ros_test_${name} test/ros/test_${name}.cpp)
  if(TARGET ros_test_${name})
    target_link_libraries(ros_test_${name} planetary_vo_ros GTest::gtest_main)
    planetary_vo_ros_target(ros_test_${name})
  endif()
endforeach()

# A short rendered Lunar descent (256 x 256, 6 s at 10 Hz) and the bag the player writes from it.
# PLANETARY_VO_TEST_DATASET: an already rendered copy of that sequence (with its bag beside it, <folder>.bag)
# is used as it is: the sanitizer build of scripts/run_tests.sh takes the main build's instead of rendering it
# again with an instrumented renderer.
set(PLANETARY_VO_TEST_DATASET "" CACHE PATH
    "Rendered VO test sequence to use instead of rendering it (the sanitizer build reuses the main build's)")
if(PLANETARY_VO_TEST_DATASET)
  set(VO_TEST_DATASET ${PLANETARY_VO_TEST_DATASET})
  set(VO_TEST_BAG ${PLANETARY_VO_TEST_DATASET}.bag)
  add_custom_target(vo_test_data)
else()
  set(VO_TEST_DATASET ${PLANETARY_VO_ROS_TEST_OUTPUT}/vo_lunar_approach_down)
  set(VO_TEST_BAG ${PLANETARY_VO_ROS_TEST_OUTPUT}/vo_lunar_approach_down.bag)
  add_custom_command(
    OUTPUT ${VO_TEST_DATASET}/times.txt
    COMMAND lunar_render --sequence approach_down --output ${VO_TEST_DATASET} --width 256 --height 256
            --duration 6 --force --no-progress --threads 2
    DEPENDS lunar_render
    COMMENT "Rendering the Lunar test sequence of the VO rostests")
  add_custom_command(
    OUTPUT ${VO_TEST_BAG}
    COMMAND player --dataset ${VO_TEST_DATASET} --bag ${VO_TEST_BAG} --no-path
    DEPENDS player ${VO_TEST_DATASET}/times.txt
    COMMENT "Writing the Lunar test bag with player --bag --no-path")
  add_custom_target(vo_test_data DEPENDS ${VO_TEST_DATASET}/times.txt ${VO_TEST_BAG})
endif()
add_dependencies(tests vo_test_data planetary_vo_nodelets vo_node)

if(TARGET GTest::gtest)
  foreach(node test_vo_node test_vo_bad_input test_vo_manager test_vo_params test_vo_fused test_hazard_node
               test_vo_fuzz)
    add_executable(${node} EXCLUDE_FROM_ALL test/ros/${node}.cpp)
    target_link_libraries(${node} planetary_vo_ros planetary_vo_eval GTest::gtest)
    target_include_directories(${node} PRIVATE ${PROJECT_SOURCE_DIR}/test/ros)
    planetary_vo_ros_target(${node})
    add_dependencies(tests ${node})
  endforeach()
  target_compile_definitions(test_vo_params PRIVATE PLANETARY_VO_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set(vo_deps planetary_vo_nodelets vo_test_data)
  add_rostest(test/ros/vo_end_to_end.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_node player ${vo_deps})
  add_rostest(test/ros/vo_bag.test ARGS bag:=${VO_TEST_BAG} dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_node ${vo_deps})
  add_rostest(test/ros/vo_reconfigure.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_node player ${vo_deps})
  foreach(case encoding info_missing size_mismatch bad_intrinsics black saturated stamps dropped resolution
               distortion mono16_bigendian absurd_intrinsics frozen stamp_jump
               stamp_restart no_frame_id exposure_drop)
    add_rostest(test/ros/vo_bad_input.test ARGS case:=${case} dataset:=${VO_TEST_DATASET}
                DEPENDENCIES test_vo_bad_input ${vo_deps})
  endforeach()
  add_rostest(test/ros/vo_bad_input.test ARGS case:=samples dataset:=${VO_TEST_DATASET}
              config:=${PROJECT_SOURCE_DIR}/config/lunar_fused.yaml
              DEPENDENCIES test_vo_bad_input ${vo_deps})
  add_rostest(test/ros/vo_reload.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_manager ${vo_deps})
  add_rostest(test/ros/vo_params.test DEPENDENCIES test_vo_params planetary_vo_nodelets)
  add_rostest(test/ros/vo_fused.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_fused player ${vo_deps})
  # Vision + altimeter (no IMU): nav/odometry at the image rate, its velocity the motion filter's.
  add_rostest(test/ros/vo_altimeter.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_fused player ${vo_deps})
  # Camera + IMU + altimeter through a dark descent: nav/odometry from the IMU alone, not confident.
  add_rostest(test/ros/vo_dead_reckoning.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_fused player ${vo_deps})
  add_rostest(test/ros/hazard_end_to_end.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_hazard_node player ${vo_deps})
  add_rostest(test/ros/vo_fuzz.test ARGS dataset:=${VO_TEST_DATASET}
              DEPENDENCIES test_vo_fuzz ${vo_deps})
endif()

# ---------------------------------------------------------------------------------------------------------------
# Fuzz test of the command-line tools (issue 12)
#   ros_test_tools_fuzz  gtest, no master: vo_run, vo_eval and player --bag on mutated files (dataset, configs,
#                        trajectories, truncated bag): success or exit code 1/2 with "<tool>: message", never a
#                        signal or a hang. Seed $PLANETARY_VO_FUZZ_SEED, cases $PLANETARY_VO_FUZZ_TOOL_CASES.
# ---------------------------------------------------------------------------------------------------------------
catkin_add_gtest(ros_test_tools_fuzz test/ros/test_tools_fuzz.cpp WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
if(TARGET ros_test_tools_fuzz)
  target_link_libraries(ros_test_tools_fuzz GTest::gtest_main)
  add_dependencies(ros_test_tools_fuzz vo_run vo_eval player vo_test_data)
  target_compile_definitions(ros_test_tools_fuzz PRIVATE
    VO_RUN_EXE="$<TARGET_FILE:vo_run>" VO_EVAL_EXE="$<TARGET_FILE:vo_eval>" PLAYER_EXE="$<TARGET_FILE:player>"
    VO_TEST_DATASET="${VO_TEST_DATASET}" PLANETARY_VO_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    PLANETARY_VO_TEST_OUTPUT_DIR="${PLANETARY_VO_ROS_TEST_OUTPUT}")
endif()

# ---------------------------------------------------------------------------------------------------------------
# Ground-truth overlay (aligned_path_node)
#   aligned_path  rostest: ground truth + a Sim(3)-transformed copy as vo/pose (stamps a few ms off, poses
#                 missing, collinear start) -> vo/path_aligned equals the ground truth, vo/ate_m ~ 0, the map
#                 goes through the same Sim(3)
# ---------------------------------------------------------------------------------------------------------------
if(TARGET GTest::gtest)
  add_executable(test_aligned_path_node EXCLUDE_FROM_ALL test/ros/test_aligned_path_node.cpp)
  target_link_libraries(test_aligned_path_node planetary_vo_ros planetary_vo_eval GTest::gtest)
  target_include_directories(test_aligned_path_node PRIVATE ${PROJECT_SOURCE_DIR}/test/ros)
  planetary_vo_ros_target(test_aligned_path_node)
  add_dependencies(tests test_aligned_path_node aligned_path_node)
  add_rostest(test/ros/aligned_path.test DEPENDENCIES test_aligned_path_node aligned_path_node)
endif()
