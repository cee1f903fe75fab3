# hapticd_driver(): a driver's library, its simulated peer and its tests,
# declared once in the driver's own drivers/<kind>/CMakeLists.txt, so that a
# new driver touches its folder and one line of drivers/registry.cpp:
#
#   hapticd_driver(canopen
#     SOURCES canopen_driver.cpp canopen_device.cpp   # -> hapticd_driver_canopen
#     LINK hapticd_canopen_master                     # its public dependencies
#     PRIVATE_LINK PkgConfig::LIBMODBUS               # and private ones
#     PEER ${PROJECT_SOURCE_DIR}/sim/canopen          # the simulated peer's folder
#     TESTS ${PROJECT_SOURCE_DIR}/tests/drivers/canopen)  # the tests' folder
#
# The library joins hapticd_drivers (the registry's library, drivers/); the
# peer's folder is added after every driver (sim/CMakeLists.txt), the tests'
# folder with the tests (tests/CMakeLists.txt). PEER and TESTS are optional:
# drivers/skeleton keeps its tests in its own folder and has no peer program.
define_property(GLOBAL PROPERTY HAPTICD_DRIVER_LIBRARIES BRIEF_DOCS "driver libraries" FULL_DOCS "hapticd_driver_<kind>")
define_property(GLOBAL PROPERTY HAPTICD_DRIVER_PEERS BRIEF_DOCS "simulated peers" FULL_DOCS "source folders")
define_property(GLOBAL PROPERTY HAPTICD_DRIVER_TESTS BRIEF_DOCS "driver tests" FULL_DOCS "source folders")

function(hapticd_driver kind)
  cmake_parse_arguments(PARSE_ARGV 1 DRIVER "" "PEER;TESTS" "SOURCES;LINK;PRIVATE_LINK")
  set(target hapticd_driver_${kind})
  add_library(${target} STATIC ${DRIVER_SOURCES})
  target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${target} PUBLIC hapticd_device ${DRIVER_LINK} PRIVATE ${DRIVER_PRIVATE_LINK} hapticd_warnings)
  set_property(GLOBAL APPEND PROPERTY HAPTICD_DRIVER_LIBRARIES ${target})
  if(DRIVER_PEER)
    set_property(GLOBAL APPEND PROPERTY HAPTICD_DRIVER_PEERS ${DRIVER_PEER})
  endif()
  if(DRIVER_TESTS)
    set_property(GLOBAL APPEND PROPERTY HAPTICD_DRIVER_TESTS ${DRIVER_TESTS})
  endif()
endfunction()

# Adds each folder of a HAPTICD_DRIVER_* property, building it where its
# source sits relative to the project (build/sim/canopen, build/tests/...).
function(hapticd_add_driver_folders property)
  get_property(folders GLOBAL PROPERTY ${property})
  foreach(folder IN LISTS folders)
    file(RELATIVE_PATH relative ${PROJECT_SOURCE_DIR} ${folder})
    add_subdirectory(${folder} ${PROJECT_BINARY_DIR}/${relative})
  endforeach()
endfunction()
