# ROS layer (thin), included by the top CMakeLists.txt. catkin's include directories are given per target, never per
# directory, so the ROS-free core libraries cannot see a ROS header.
#
#   planetary_vo_ros  conversions core types <-> messages, and the dataset player core (stream, bag writer)
#   player            the dataset player: ROS node, or `player --dataset DIR --bag OUT.bag` to write a bag

add_library(planetary_vo_ros STATIC
  ${PROJECT_SOURCE_DIR}/src/ros/conversions.cpp
  ${PROJECT_SOURCE_DIR}/src/ros/player.cpp)
set_target_properties(planetary_vo_ros PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_include_directories(planetary_vo_ros PUBLIC ${PROJECT_SOURCE_DIR}/include)
target_include_directories(planetary_vo_ros SYSTEM PUBLIC ${catkin_INCLUDE_DIRS})
target_link_libraries(planetary_vo_ros PUBLIC planetary_vo_dataset ${catkin_LIBRARIES})
add_dependencies(planetary_vo_ros ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS})

add_executable(player ${PROJECT_SOURCE_DIR}/src/ros/player_node.cpp)
target_link_libraries(player planetary_vo_ros)
add_dependencies(player ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS})
