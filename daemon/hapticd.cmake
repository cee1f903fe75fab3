# The daemon's own wiring (engine, planner, service) and the hapticd binary.
add_library(hapticd_daemon_core STATIC
  ${CMAKE_CURRENT_SOURCE_DIR}/engine/engine.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/engine/safety.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/engine/task_cycle.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/planner.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/device_model.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/device_factory.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/service.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/task_overlay.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/calibration.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/calibration_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/status_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/scene_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/record_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/fault_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/device_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/model_methods.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/methods/telemetry_methods.cpp)
target_include_directories(hapticd_daemon_core PUBLIC ${PROJECT_SOURCE_DIR})
target_compile_definitions(hapticd_daemon_core PUBLIC HAPTICD_VERSION="${PROJECT_VERSION}")
target_link_libraries(hapticd_daemon_core
  PUBLIC hapticd_rt hapticd_system hapticd_analysis hapticd_world hapticd_drivers hapticd_config hapticd_recorder
         hapticd_control hapticd_telemetry nlohmann_json::nlohmann_json
  PRIVATE hapticd_warnings)

add_executable(hapticd ${CMAKE_CURRENT_SOURCE_DIR}/main.cpp)
target_link_libraries(hapticd PRIVATE hapticd_daemon_core hapticd_setup_check CLI11::CLI11 hapticd_warnings)
install(TARGETS hapticd RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
