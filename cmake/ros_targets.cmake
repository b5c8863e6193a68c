# ROS layer (thin), included by the top CMakeLists.txt. catkin's include directories are given per target, never per
# directory, so the ROS-free core libraries cannot see a ROS header.
#
#   planetary_vo_ros  conversions core types <-> messages, and the dataset player core (stream, bag writer)
#   player            the dataset player: ROS node, or `player --dataset DIR --bag OUT.bag` to write a bag

# Gives a target that uses ROS headers catkin's include directories (per target: the core libraries never see
# them) and makes it wait for the generated messages. Every ROS-layer target calls it, including the tests.
function(planetary_vo_ros_target target)
  target_include_directories(${target} SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  add_dependencies(${target} ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS})
endfunction()

add_library(planetary_vo_ros STATIC
  ${PROJECT_SOURCE_DIR}/src/ros/conversions.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/player.cpp)
set_target_properties(planetary_vo_ros PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_include_directories(planetary_vo_ros PUBLIC ${PROJECT_SOURCE_DIR}/include)
target_link_libraries(planetary_vo_ros PUBLIC planetary_vo_dataset ${catkin_LIBRARIES})
planetary_vo_ros_target(planetary_vo_ros)

add_executable(player ${PROJECT_SOURCE_DIR}/src/ros/player_node.cpp)
target_link_libraries(player planetary_vo_ros)
planetary_vo_ros_target(player)
install(TARGETS player RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
