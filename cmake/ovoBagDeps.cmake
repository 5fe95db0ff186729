# Dependencies of ovo's bag readers (io/), as imported targets; included by CMakeLists.txt and by
# the installed ovoConfig.cmake (a consumer of the static libraries links the same). All are
# Debian packages (scripts/setup.sh): librosbag-storage-dev and libsensor-msgs-dev (ROS 1 bags,
# no ROS installation needed), libsqlite3-dev, libzstd-dev, liblz4-dev, libbz2-dev.
include_guard(GLOBAL)

find_package(SQLite3 REQUIRED)
find_package(BZip2 REQUIRED)

find_path(OVO_ZSTD_INCLUDE_DIR zstd.h REQUIRED)
find_library(OVO_ZSTD_LIBRARY zstd REQUIRED)
find_path(OVO_LZ4_INCLUDE_DIR lz4frame.h REQUIRED)
find_library(OVO_LZ4_LIBRARY lz4 REQUIRED)
if(NOT TARGET ovo::zstd)
  add_library(ovo::zstd INTERFACE IMPORTED)
  target_include_directories(ovo::zstd INTERFACE ${OVO_ZSTD_INCLUDE_DIR})
  target_link_libraries(ovo::zstd INTERFACE ${OVO_ZSTD_LIBRARY})
endif()
if(NOT TARGET ovo::lz4)
  add_library(ovo::lz4 INTERFACE IMPORTED)
  target_include_directories(ovo::lz4 INTERFACE ${OVO_LZ4_INCLUDE_DIR})
  target_link_libraries(ovo::lz4 INTERFACE ${OVO_LZ4_LIBRARY})
endif()

# ROS 1 (Debian's catkin-built packages), unless ovo is built without (OVO_WITH_ROS1=OFF):
# rosbag/bag.h includes pluginlib, class_loader, rcutils, rcpputils and ament_index_cpp headers,
# each under its own folder of /usr/include.
if(DEFINED OVO_WITH_ROS1 AND NOT OVO_WITH_ROS1)
  return()
endif()
find_path(OVO_ROSBAG_INCLUDE_DIR rosbag/bag.h REQUIRED)
find_path(OVO_SENSOR_MSGS_INCLUDE_DIR sensor_msgs/LaserScan.h REQUIRED)
set(_ovo_ros1_includes ${OVO_ROSBAG_INCLUDE_DIR} ${OVO_SENSOR_MSGS_INCLUDE_DIR})
foreach(_pair "pluginlib;pluginlib/class_loader.hpp" "class_loader;class_loader/class_loader.hpp"
              "rcutils;rcutils/types.h" "rcpputils;rcpputils/filesystem_helper.hpp"
              "ament_index_cpp;ament_index_cpp/get_package_prefix.hpp")
  list(GET _pair 0 _dir)
  list(GET _pair 1 _header)
  find_path(OVO_${_dir}_INCLUDE_DIR ${_header} PATH_SUFFIXES ${_dir} REQUIRED)
  list(APPEND _ovo_ros1_includes ${OVO_${_dir}_INCLUDE_DIR})
endforeach()
set(_ovo_ros1_libs)
foreach(_lib rosbag_storage roslz4 rostime cpp_common roscpp_serialization console_bridge)
  find_library(OVO_${_lib}_LIBRARY ${_lib} REQUIRED)
  list(APPEND _ovo_ros1_libs ${OVO_${_lib}_LIBRARY})
endforeach()
if(NOT TARGET ovo::ros1)
  add_library(ovo::ros1 INTERFACE IMPORTED)
  target_include_directories(ovo::ros1 INTERFACE ${_ovo_ros1_includes})
  target_link_libraries(ovo::ros1 INTERFACE ${_ovo_ros1_libs})
endif()
