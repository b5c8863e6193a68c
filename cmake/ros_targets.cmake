# ROS layer (thin), included by the top CMakeLists.txt. catkin's include directories are given per target, never per
# directory, so the ROS-free core libraries cannot see a ROS header.
#
#   planetary_vo_ros       conversions core types <-> messages (VO, map events, hazard products), the dataset
#                          player core (stream, bag writer), the VO output conversions and input checks, ros_params,
#                          status_reporter
#   planetary_vo_nodelets  the nodelets planetary_vo/VisualOdometryNodelet and planetary_vo/HazardNodelet
#                          (nodelet_plugins.xml)
#   player                 the dataset player: ROS node, or `player --dataset DIR --bag OUT.bag` to write a bag
#   vo_node                the nodelet in an in-process loader, for use without a manager
#   trajectory_recorder    PoseStamped topic -> TUM file
#   hazard_recorder        hazard/map + hazard/landing_sites -> terrain.yaml + landing_sites.yaml (terrain_eval)
#   terrain_truth_node     display aid: the dataset's true terrain -> ground_truth/terrain_cloud, ground_truth/hazard
#   aligned_path_node      ground-truth overlay for rviz (display/evaluation aid): vo/pose through a running Sim(3)
#                          onto ground_truth/pose -> vo/path_aligned, vo/ate_m, vo/map_points_aligned

# The nodelet's extra packages (tf2, diagnostics, dynamic_reconfigure) are catkin components of the top-level
# find_package, so catkin_INCLUDE_DIRS / catkin_LIBRARIES carry them; the reconfigure header is generated there too.

# Gives a target that uses ROS headers catkin's include directories (per target: the core libraries never see
# them) and makes it wait for the generated messages. Every ROS-layer target calls it, including the tests.
function(planetary_vo_ros_target target)
  target_include_directories(${target} SYSTEM PRIVATE ${catkin_INCLUDE_DIRS}
                             ${CATKIN_DEVEL_PREFIX}/${CATKIN_GLOBAL_INCLUDE_DESTINATION})
  add_dependencies(${target} ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS} ${PROJECT_NAME}_gencfg)
endfunction()

add_library(planetary_vo_ros STATIC
  ${PROJECT_SOURCE_DIR}/src/ros/conversions.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/player.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/vo_conversions.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/map_event_conversions.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/hazard_conversions.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/ros_params.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/status_reporter.cpp)
set_target_properties(planetary_vo_ros PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_include_directories(planetary_vo_ros PUBLIC ${PROJECT_SOURCE_DIR}/include)
target_link_libraries(planetary_vo_ros PUBLIC planetary_vo_dataset planetary_vo_vo planetary_vo_eval
                      planetary_vo_terrain ${catkin_LIBRARIES})
planetary_vo_ros_target(planetary_vo_ros)

add_library(planetary_vo_nodelets SHARED ${PROJECT_SOURCE_DIR}/src/ros/vo_nodelet.cpp
            ${PROJECT_SOURCE_DIR}/src/ros/hazard_nodelet.cpp)
target_link_libraries(planetary_vo_nodelets planetary_vo_ros)
planetary_vo_ros_target(planetary_vo_nodelets)

add_executable(player ${PROJECT_SOURCE_DIR}/src/ros/player_node.cpp)
target_link_libraries(player planetary_vo_ros)
planetary_vo_ros_target(player)

add_executable(vo_node ${PROJECT_SOURCE_DIR}/src/ros/vo_node.cpp)
target_link_libraries(vo_node ${catkin_LIBRARIES})
planetary_vo_ros_target(vo_node)
add_dependencies(vo_node planetary_vo_nodelets)  # loads it at run time

add_executable(trajectory_recorder ${PROJECT_SOURCE_DIR}/src/ros/trajectory_recorder.cpp)
target_link_libraries(trajectory_recorder ${catkin_LIBRARIES})
planetary_vo_ros_target(trajectory_recorder)

add_executable(hazard_recorder ${PROJECT_SOURCE_DIR}/src/ros/hazard_recorder.cpp)
target_link_libraries(hazard_recorder planetary_vo_ros)
planetary_vo_ros_target(hazard_recorder)

add_executable(terrain_truth_node ${PROJECT_SOURCE_DIR}/src/ros/terrain_truth_node.cpp)
target_link_libraries(terrain_truth_node planetary_vo_ros)
planetary_vo_ros_target(terrain_truth_node)

add_executable(aligned_path_node ${PROJECT_SOURCE_DIR}/src/ros/aligned_path_node.cpp)
target_link_libraries(aligned_path_node planetary_vo_ros planetary_vo_eval)
planetary_vo_ros_target(aligned_path_node)
install(TARGETS aligned_path_node RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

install(TARGETS player vo_node trajectory_recorder hazard_recorder terrain_truth_node RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(TARGETS planetary_vo_nodelets
        ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
        LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION})
install(FILES nodelet_plugins.xml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
